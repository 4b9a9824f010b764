// Python values → the library's units, checked by the library's own rules
// (lec::parse_field: the manual's ranges, at most two decimals of mm), so
// Python refuses exactly what `lec` refuses, with the same words.

#include <fmt/format.h>

#include <cmath>

#include "bindings.hpp"
#include "lec6/client/errors.hpp"

namespace lec6::python {
namespace {

// The text a person would have typed for the value.
std::string value_text(const lec::StepFieldInfo& info, py::handle value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "True" : "False";
  if (py::isinstance<py::int_>(value)) return py::str(value).cast<std::string>();
  if (py::isinstance<py::float_>(value)) {
    const double v = value.cast<double>();
    // 150.1 is 150.09999999999999 as a double: a value within a hair of a
    // hundredth means that hundredth. Anything else keeps all its digits, so
    // parse_field says it has too many decimals.
    const double hundredths = v * 100.0;
    if (info.is_length && std::isfinite(v) && std::abs(hundredths - std::round(hundredths)) < 1e-6)
      return fmt::format("{:.2f}", v);
    if (!info.is_length && std::isfinite(v) && v == std::floor(v) && std::abs(v) < 1e15)
      return fmt::format("{:.0f}", v);
    return fmt::format("{}", v);
  }
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  throw py::type_error(
      fmt::format("{}: expected a number{}, got {}", info.name,
                  info.unit.empty() ? "" : fmt::format(" ({})", info.unit),
                  py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>()));
}

}  // namespace

int64_t field_value(lec::StepField field, py::handle value, std::string_view keyword) {
  const auto& info = lec::field_info(field);
  const std::string text = value_text(info, value);
  auto parsed = lec::parse_field(field, text);
  if (!parsed) {
    // "speed 70000 mm/s is out of range: allowed 1 to 65535"; prefixed with
    // the keyword when it is not the field's own name ("to: position ...").
    const bool same = keyword.empty() || keyword == info.name || keyword == info.csv_column;
    throw client::InvalidRequest(same ? parsed.error()
                                      : fmt::format("{}: {}", keyword, parsed.error()));
  }
  return *parsed;
}

Duration seconds_arg(double seconds, std::string_view keyword) {
  if (!std::isfinite(seconds) || seconds <= 0 || seconds > 1e6) {
    throw client::InvalidRequest(fmt::format(
        "{}={}: expected a number of seconds, > 0 and at most 1000000", keyword, seconds));
  }
  return to_duration(FractionalSeconds(seconds));
}

}  // namespace lec6::python
