#pragma once
// The exceptions of liblec6 share one base, so a program can catch everything
// the library throws with one clause:
//
//   try { ... } catch (const lec6::Error& e) { std::cerr << e.what() << '\n'; }
//
// Below it, by who is at fault:
//   InvalidArgument  the caller gave something unusable (a port spec, an
//                    option, a configuration, a request out of range); nothing
//                    was done. client::InvalidRequest is one.
//   SystemError      an operating-system call failed (errno); what() words it
//                    as std::system_error does: "<call>: <strerror>".
//   client::LinkError, client::TransportError, client::ControllerException,
//   client::AlarmError, client::DeadlineError, client::Cancelled
//                    (lec6/client/link.hpp, lec6/client/errors.hpp).
//
// Thread safety: exception objects are immutable; copies may be used from any thread.

#include <stdexcept>
#include <string>
#include <system_error>

namespace lec6 {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A value the caller gave is not acceptable. The message names the value and
// what is allowed, in the user's terms.
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

// An operating-system call failed.
class SystemError : public Error {
 public:
  // `err` is an errno value; `call` names what failed ("poll", "eventfd").
  SystemError(int err, const std::string& call)
      : Error(call + ": " + std::generic_category().message(err)),
        code_(err, std::generic_category()) {}
  const std::error_code& code() const noexcept { return code_; }

 private:
  std::error_code code_;
};

}  // namespace lec6
