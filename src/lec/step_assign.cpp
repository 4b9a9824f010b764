#include "lec6/lec/step_assign.hpp"
#include "lec6/lec/step_defaults.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cctype>

#include "lec6/lec/nearest.hpp"

namespace lec6::lec {
namespace {

std::string_view trim_value(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Lower case, '-' as '_': the spelling find_step_field compares.
std::string normalise_field(std::string_view s) {
  std::string out;
  for (char c : s) {
    out.push_back(c == '-' ? '_' : static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  return out;
}

std::string field_names(std::span<const StepField> fields) {
  std::vector<std::string_view> names;
  for (StepField f : fields) names.push_back(field_info(f).name);
  return fmt::format("{}", fmt::join(names, ", "));
}

}  // namespace

std::string unknown_field_message(std::string_view name) {
  const std::string n = normalise_field(trim_value(name));
  std::vector<const StepFieldInfo*> owners;  // of each candidate spelling
  std::vector<std::string> spellings;
  for (const auto& i : step_fields()) {
    for (std::string_view candidate : {i.name, i.long_name, i.csv_column}) {
      owners.push_back(&i);
      spellings.push_back(normalise_field(candidate));
    }
  }
  const auto best = nearest_index(n, spellings);
  std::vector<std::string_view> known;
  for (const auto& i : step_fields()) known.push_back(i.name);
  const std::string hint =
      best ? fmt::format(" did you mean '{}'?", owners[*best]->name) : std::string();
  return fmt::format("unknown field '{}':{} known fields are {}", trim_value(name), hint,
                     fmt::join(known, ", "));
}

Expected<StepAssignment, std::string> parse_assignment(std::string_view arg) {
  const auto eq = arg.find('=');
  const std::string_view name =
      eq == std::string_view::npos ? std::string_view{} : trim_value(arg.substr(0, eq));
  if (name.empty()) {
    return unexpected(fmt::format("'{}' is not field=value (e.g. speed=500)", arg));
  }
  const StepFieldInfo* info = find_step_field(name);
  if (!info) return unexpected(unknown_field_message(name));
  const std::string_view value = trim_value(arg.substr(eq + 1));
  if (value.empty()) {
    return unexpected(fmt::format("{}: no value after '=' (e.g. {}=...)", info->name, info->name));
  }
  auto v = parse_field(info->field, value);
  if (!v) return unexpected(v.error());
  return StepAssignment{info->field, *v};
}

Expected<std::vector<StepAssignment>, AssignErrors> parse_assignments(
    std::span<const std::string> args) {
  AssignErrors errors;
  std::vector<StepAssignment> out;
  std::array<std::string, kStepFieldCount> given;  // the argument that set each field
  for (const std::string& arg : args) {
    auto a = parse_assignment(arg);
    if (!a) {
      errors.push_back(a.error());
      continue;
    }
    std::string& first = given[static_cast<std::size_t>(a->field)];
    if (!first.empty()) {
      errors.push_back(fmt::format("{} is given twice ('{}' and '{}'): give each field once",
                                   field_info(a->field).name, first, arg));
      continue;
    }
    first = arg;
    out.push_back(*a);
  }
  if (!errors.empty()) return unexpected(std::move(errors));
  return out;
}

Expected<AssignResult, AssignErrors> apply_assignments(unsigned step, const StepData& current,
                                                       std::span<const StepAssignment> assignments,
                                                       const std::optional<CopySource>& from) {
  if (from && from->data.is_blank()) {
    return unexpected(AssignErrors{fmt::format(
        "step {} is blank: there is nothing to copy with --from {}", from->step, from->step)});
  }
  if (assignments.empty() && !from) {
    return unexpected(
        AssignErrors{fmt::format("nothing to set for step {}: give field=value (e.g. speed=500) "
                                 "or copy a step with --from M",
                                 step)});
  }
  // A blank step starts from the one set of defaults (step_defaults.hpp),
  // as PUT /steps/N and the dashboard do; the result names what they filled.
  const StepData base = from ? from->data : current;
  StepData result = base.is_blank() ? default_step_data() : base;
  std::array<bool, kStepFieldCount> assigned{};
  for (const auto& a : assignments) {
    set_field(result, a.field, a.raw);
    assigned[static_cast<std::size_t>(a.field)] = true;
  }

  AssignErrors errors;
  std::vector<StepField> missing;
  for (const auto& issue : validate(result)) {
    const bool was_assigned = assigned[static_cast<std::size_t>(issue.field)];
    if (base.is_blank() && !was_assigned) {
      if (std::find(missing.begin(), missing.end(), issue.field) == missing.end()) {
        missing.push_back(issue.field);
      }
    } else {
      errors.push_back(fmt::format("step {}: {}", step, issue.message));
    }
  }
  if (!missing.empty()) {
    std::sort(missing.begin(), missing.end());
    errors.insert(errors.begin(),
                  fmt::format("step {} is blank: also give {}, or copy a step with --from M", step,
                              field_names(missing)));
  }
  if (!errors.empty()) return unexpected(std::move(errors));

  AssignResult out{result, {}, {}, {}};
  for (const auto& i : step_fields()) {
    if (get_field(result, i.field) != get_field(current, i.field)) out.changed.push_back(i.field);
    if (base.is_blank() && !assigned[static_cast<std::size_t>(i.field)] &&
        get_field(result, i.field) != 0)
      out.defaulted.push_back(i.field);
  }
  if (result.moving_force_pct == 0) {
    out.warnings.push_back(fmt::format(
        "step {}: moving force is 0 %: the actuator may not move (give moving-force=100)", step));
  }
  return out;
}

Expected<AssignResult, AssignErrors> assign_step(unsigned step, const StepData& current,
                                                 std::span<const std::string> args,
                                                 const std::optional<CopySource>& from) {
  auto parsed = parse_assignments(args);
  if (!parsed) return unexpected(parsed.error());
  return apply_assignments(step, current, *parsed, from);
}

}  // namespace lec6::lec
