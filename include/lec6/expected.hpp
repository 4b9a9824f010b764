#pragma once
// A minimal value-or-error type with std::expected's spelling (C++23).
//
// Why not std::expected: the library is C++20, and libstdc++ 12's <expected>
// needs C++23 concepts that clang 14 (the sanitizer tree's compiler) does not
// report; and std::bad_expected_access is no lec6::Error, so the one
// `catch (const lec6::Error&)` that error.hpp promises would miss it.
//
// Reading the value of an Expected that holds an error (value(), *, ->)
// throws lec6::BadExpectedAccess, a lec6::Error whose what() is the error's
// message (see describe_error below), in every build type. has_value() or
// operator bool first is the way to use it without exceptions.
//
// Thread safety: as the values it holds.

#include <cassert>
#include <concepts>
#include <iterator>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include "lec6/error.hpp"

namespace lec6 {

// The error of an Expected, in words, for BadExpectedAccess::what(): a
// string as it is, a struct's `message`, a list of strings joined by "; ".
template <typename E>
std::string describe_error(const E& e) {
  if constexpr (std::is_convertible_v<const E&, std::string_view>) {
    return std::string(std::string_view(e));
  } else if constexpr (requires { std::string(e.message); }) {
    return std::string(e.message);
  } else if constexpr (requires {
                         std::begin(e);
                         std::string_view(*std::begin(e));
                       }) {
    std::string out;
    for (const auto& item : e) {
      if (!out.empty()) out += "; ";
      out += std::string_view(item);
    }
    return out;
  } else {
    return "an error value";
  }
}

// value() was asked of an Expected that holds an error. Catch it as
// lec6::Error (what() says what the error was) or as BadExpectedAccessOf<E>
// to get the error itself.
class BadExpectedAccess : public Error {
 public:
  using Error::Error;
};

template <typename E>
class BadExpectedAccessOf : public BadExpectedAccess {
 public:
  explicit BadExpectedAccessOf(E error)
      : BadExpectedAccess(describe_error(error)), error_(std::move(error)) {}
  const E& error() const noexcept { return error_; }

 private:
  E error_;
};

template <typename E>
struct Unexpected {
  E error;
};
template <typename E>
Unexpected(E) -> Unexpected<E>;

template <typename E>
constexpr Unexpected<std::decay_t<E>> unexpected(E&& e) {
  return {std::forward<E>(e)};
}

template <typename T, typename E>
class Expected {
 public:
  Expected(T value) : v_(std::in_place_index<0>, std::move(value)) {}  // NOLINT implicit
  template <typename G>
  Expected(Unexpected<G> u) : v_(std::in_place_index<1>, E(std::move(u.error))) {}  // NOLINT

  bool has_value() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return has_value(); }

  // Throw BadExpectedAccessOf<E> when this holds an error.
  T& value() & {
    check();
    return std::get<0>(v_);
  }
  const T& value() const& {
    check();
    return std::get<0>(v_);
  }
  T&& value() && {
    check();
    return std::get<0>(std::move(v_));
  }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  // Only when !has_value() (asserted).
  const E& error() const& {
    assert(!has_value());
    return std::get<1>(v_);
  }
  E& error() & {
    assert(!has_value());
    return std::get<1>(v_);
  }

 private:
  void check() const {
    if (!has_value()) throw BadExpectedAccessOf<E>(std::get<1>(v_));
  }

  std::variant<T, E> v_;
};

// Expected<void, E>: success carries nothing.
template <typename E>
class Expected<void, E> {
 public:
  Expected() = default;
  template <typename G>
  Expected(Unexpected<G> u) : error_(E(std::move(u.error))), ok_(false) {}  // NOLINT

  bool has_value() const noexcept { return ok_; }
  explicit operator bool() const noexcept { return ok_; }
  // Nothing to return: throws BadExpectedAccessOf<E> when this holds an error.
  void value() const {
    if (!ok_) throw BadExpectedAccessOf<E>(error_);
  }
  const E& error() const& {
    assert(!ok_);
    return error_;
  }

 private:
  E error_{};
  bool ok_ = true;
};

}  // namespace lec6
