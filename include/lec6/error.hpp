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
//   twin::ProfileError a twin field profile it cannot use (an InvalidArgument).
//   BadExpectedAccess value() of an Expected that holds an error
//                    (lec6/expected.hpp): a bug in the caller, who should
//                    have looked at has_value() first.
//
// When the library throws and when it returns an error:
//   - It RETURNS an error (lec6::Expected<T, E>, or std::optional<Error> for a
//     check) from the pure functions that read text or bytes a user or a peer
//     supplied, where a wrong input is an expected answer rather than an
//     accident, and where all the errors can be listed at once: the Modbus
//     codec (modbus/pdu.hpp decode_*/encode_*, from_hex), the LEC values and
//     step tables (lec/units.hpp, step_data.hpp parse_field, step_table.hpp,
//     step_assign.hpp, EquipmentName::make), the twin's state files
//     (sim/state_file.hpp, twin/state_file_io.hpp) and the file helpers
//     (transport/file.hpp, transport/step_table_file.hpp). Nothing is done
//     when they fail.
//   - It THROWS (one of the classes above) from everything that does I/O or
//     acts: Client, Actuator, Follower, step_sync, every Master and Link,
//     open_port, the servers; and from constructors and option checks given
//     something unusable (InvalidArgument, before anything was done). A step
//     restore reports per-step failures in its result (step_sync.hpp) and
//     throws only for the reads before any write.
//   - Never: a destructor; stops_or_releases and the other pure predicates.
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
        code_(err, std::generic_category()),
        call_(call) {}
  const std::error_code& code() const noexcept { return code_; }
  // The call that failed, as given ("poll", "read").
  const std::string& call() const noexcept { return call_; }

 private:
  std::error_code code_;
  std::string call_;
};

}  // namespace lec6
