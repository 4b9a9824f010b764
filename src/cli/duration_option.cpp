#include "cli/duration_option.hpp"

#include <fmt/format.h>

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>

namespace lec6::cli {

namespace {

struct Unit {
  std::string_view suffix;
  FractionalSeconds size;
};

// Longest suffixes first so "ms" is not read as "m" + "s".
constexpr std::array kUnits{
    Unit{"min", FractionalSeconds(60.0)}, Unit{"ms", FractionalSeconds(1e-3)},
    Unit{"us", FractionalSeconds(1e-6)},  Unit{"\u00B5s", FractionalSeconds(1e-6)},
    Unit{"ns", FractionalSeconds(1e-9)},  Unit{"s", FractionalSeconds(1.0)},
};

constexpr const char* kForms = "write a number and a unit, e.g. 500ms, 2s, 1.5s, 250us or 2min";

std::string_view trim_spaces(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

FractionalSeconds bare_unit(BareNumber bare) {
  return bare == BareNumber::Seconds ? FractionalSeconds(1.0) : FractionalSeconds(1e-3);
}

std::string_view bare_suffix(BareNumber bare) {
  return bare == BareNumber::Seconds ? "s" : "ms";
}

// How the old spelling reads in the new syntax: "5" → "5s".
std::string in_unit(const std::string& text, BareNumber bare) {
  return text + std::string(bare_suffix(bare));
}

void check_limits(const std::string& name, const std::string& text, Duration d,
                  const DurationLimits& limits) {
  if (d < limits.min || d > limits.max) {
    throw CLI::ValidationError(
        name, fmt::format("{} is out of range: {} to {}", text, format_duration(limits.min),
                          format_duration(limits.max)));
  }
  if (limits.resolution.count() > 0 && d % limits.resolution != Duration::zero()) {
    throw CLI::ValidationError(name, fmt::format("{} is not a whole multiple of {}", text,
                                                 format_duration(limits.resolution)));
  }
}

// Both kinds of old spelling print the same hint, so users learn one syntax.
void warn_deprecated(const std::string& old_spelling, const std::string& new_spelling,
                     const std::string& why) {
  fmt::print(stderr, "lec: warning: {} is deprecated{}; write {}\n", old_spelling, why,
             new_spelling);
}

}  // namespace

DurationText parse_duration(std::string_view text) {
  const std::string_view s = trim_spaces(text);
  double number = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), number);
  if (ec != std::errc() || end == s.data() || !std::isfinite(number)) {
    throw InvalidArgument(fmt::format("'{}' is not a duration: {}", text, kForms));
  }
  const std::string_view rest = trim_spaces(s.substr(static_cast<std::size_t>(end - s.data())));
  if (rest.empty()) return {to_duration(FractionalSeconds(number)), number, false};
  for (const Unit& u : kUnits) {
    if (rest == u.suffix) return {to_duration(number * u.size), number, true};
  }
  throw InvalidArgument(fmt::format("'{}' has no known unit ('{}'): {}", text, rest, kForms));
}

std::string format_duration(Duration d) {
  using namespace std::chrono;
  if (d < Duration::zero()) return "-" + format_duration(-d);
  const auto decimals = [](double value, const char* unit) {
    std::string t = fmt::format("{:.3f}", value);
    while (t.back() == '0') t.pop_back();
    if (t.back() == '.') t.pop_back();
    return t + unit;
  };
  if (d % seconds(1) == Duration::zero()) return fmt::format("{}s", d / seconds(1));
  if (d >= seconds(1) && d % milliseconds(1) == Duration::zero())
    return decimals(to_seconds(d), "s");
  if (d % milliseconds(1) == Duration::zero()) return fmt::format("{}ms", d / milliseconds(1));
  if (d >= milliseconds(1) && d % microseconds(1) == Duration::zero())
    return decimals(to_ms(d), "ms");
  if (d % microseconds(1) == Duration::zero()) return fmt::format("{}us", d / microseconds(1));
  return fmt::format("{}ns", d.count());
}

CLI::Option* add_duration_option(CLI::App* app, const std::string& name, Duration& out,
                                 const std::string& help, DurationLimits limits, BareNumber bare) {
  // "-i,--interval" is shown as "--interval" in messages.
  const std::string shown =
      name.substr(name.rfind(',') == std::string::npos ? 0 : name.rfind(',') + 1);
  auto parse = [name = shown, &out, limits, bare](const std::string& text) {
    DurationText t{};
    try {
      t = parse_duration(text);
    } catch (const InvalidArgument& e) {
      throw CLI::ValidationError(name, e.what());
    }
    // A bare 0 is the same in every unit, so it needs none.
    const bool old_spelling = !t.had_unit && t.number != 0.0;
    if (old_spelling && bare == BareNumber::Refused) {
      throw CLI::ValidationError(name, fmt::format("'{}' needs a unit: {}", text, kForms));
    }
    const std::string typed = old_spelling ? in_unit(text, bare) : text;
    if (old_spelling) t.value = to_duration(t.number * bare_unit(bare));
    check_limits(name, typed, t.value, limits);
    if (old_spelling) {
      warn_deprecated(fmt::format("'{} {}' (a number without a unit)", name, text),
                      fmt::format("{} {}", name, typed), "");
    }
    out = t.value;
  };
  return app->add_option_function<std::string>(name, parse, help)
      ->type_name("DURATION")
      ->default_str(format_duration(out));
}

CLI::Option* add_renamed_duration_option(CLI::App* app, const std::string& old_name,
                                         const std::string& new_name, Duration& out,
                                         BareNumber unit, DurationLimits limits, std::string hint) {
  auto parse = [old_name, new_name, &out, limits, unit, hint](const std::string& text) {
    DurationText t{};
    try {
      t = parse_duration(text);
    } catch (const InvalidArgument& e) {
      throw CLI::ValidationError(
          old_name, fmt::format("{} ({} is deprecated: use {})", e.what(), old_name, new_name));
    }
    // The old option took a number in `unit`; a unit given anyway is honoured.
    const std::string typed = t.had_unit ? text : in_unit(text, unit);
    const Duration d = t.had_unit ? t.value : to_duration(t.number * bare_unit(unit));
    check_limits(old_name, typed, d, limits);
    warn_deprecated(fmt::format("{} {}", old_name, text), fmt::format("{} {}", new_name, typed),
                    hint);
    out = d;
  };
  return app->add_option_function<std::string>(old_name, parse, "Deprecated: use " + new_name)
      ->group("");  // hidden from --help
}

CLI::Option* add_deadline_option(CLI::App* app, Duration& out, const std::string& help) {
  const DurationLimits limits{std::chrono::milliseconds(1), std::chrono::hours(24)};
  add_renamed_duration_option(app, "--timeout-s", "--timeout", out, BareNumber::Seconds, limits);
  return add_duration_option(app, "--timeout", out, help, limits);
}

}  // namespace lec6::cli
