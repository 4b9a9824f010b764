// Step tables as JSON. The format and its rules are described in
// include/lec6/lec/step_table.hpp; the checks are the CSV reader's.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <nlohmann/json.hpp>
#include <set>

#include "lec/step_table_internal.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::lec {
namespace {

using detail::lower;
using json = nlohmann::json;

std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20) {
      out += fmt::format("\\u{:04x}", u);
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// A value as the text a person would have typed, for parse_field.
std::optional<std::string> value_text(const json& v) {
  switch (v.type()) {
    case json::value_t::string:
      return v.get<std::string>();
    case json::value_t::number_integer:
      return fmt::format("{}", v.get<int64_t>());
    case json::value_t::number_unsigned:
      return fmt::format("{}", v.get<uint64_t>());
    // Shortest text that reads back as the same double: 150.07 → "150.07".
    case json::value_t::number_float:
      return fmt::format("{}", v.get<double>());
    default:
      return std::nullopt;
  }
}

}  // namespace

std::string to_json(const StepTable& table) {
  std::string out = "{\n";
  out += fmt::format("  \"equipment_name\": {},\n", json_string(table.equipment_name));
  out += fmt::format("  \"controller_id\": {},\n", table.controller_id);
  out += "  \"steps\": [";
  bool first = true;
  for (unsigned s = 0; s < StepTable::kSteps; ++s) {
    if (!table.covers(s)) continue;
    out += first ? "\n" : ",\n";
    first = false;
    const StepData& d = table.steps[s];
    out += fmt::format("    {{\"step\": {}", s);
    for (const auto& i : step_fields()) {
      const int64_t v = get_field(d, i.field);
      const std::string text = i.field == StepField::MovementMode
                                   ? json_string(format_field(i.field, v))
                                   : format_field(i.field, v);
      out += fmt::format(", \"{}\": {}", i.csv_column, text);
    }
    out += "}";
  }
  out += first ? "]\n}\n" : "\n  ]\n}\n";
  return out;
}

Expected<StepTable, TableErrors> parse_json(std::string_view text) {
  TableErrors errors;
  // nlohmann keeps the last of repeated keys; find repeats while parsing.
  std::vector<std::set<std::string>> keys;
  const json::parser_callback_t note_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) keys.emplace_back();
    if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    if (event == json::parse_event_t::key && !keys.empty()) {
      const auto k = parsed.get<std::string>();
      if (!keys.back().insert(k).second) {
        errors.push_back(fmt::format("key '{}' appears twice in one object", k));
      }
    }
    return true;
  };
  json doc;
  try {
    doc = json::parse(text.begin(), text.end(), note_keys);
  } catch (const json::parse_error& e) {
    return unexpected(TableErrors{fmt::format("not valid JSON: {}", e.what())});
  } catch (const json::out_of_range& e) {  // e.g. a number like 1e400 that no field can hold
    return unexpected(
        TableErrors{fmt::format("a number in the JSON is out of range: {}", e.what())});
  }
  if (!doc.is_object()) {
    return unexpected(TableErrors{
        "the JSON must be an object with \"equipment_name\", \"controller_id\" and \"steps\""});
  }

  StepTable meta;
  const json* steps = nullptr;
  for (const auto& [key, value] : doc.items()) {
    const std::string k = lower(key);
    if (k == "equipment_name") {
      if (!value.is_string()) {
        errors.push_back("equipment_name must be a string");
        continue;
      }
      auto v = detail::parse_equipment_name(value.get<std::string>());
      if (v) {
        meta.equipment_name = *v;
      } else {
        errors.push_back(v.error());
      }
    } else if (k == "controller_id") {
      const auto t = value_text(value);
      auto v = detail::parse_controller_id(t.value_or(value.dump()));
      if (v) {
        meta.controller_id = *v;
      } else {
        errors.push_back(v.error());
      }
    } else if (k == "steps") {
      steps = &value;
    } else {
      errors.push_back(fmt::format(
          "unknown key '{}': known keys are equipment_name, controller_id, steps", key));
    }
  }
  if (!steps || !steps->is_array()) {
    errors.push_back("\"steps\" must be an array of step objects");
    return unexpected(std::move(errors));
  }

  detail::TableBuilder builder;
  for (std::size_t n = 0; n < steps->size(); ++n) {
    const json& obj = (*steps)[n];
    const std::string at = fmt::format("steps[{}]", n);
    if (!obj.is_object()) {
      errors.push_back(fmt::format("{}: must be an object", at));
      continue;
    }
    std::optional<std::string> step_text;
    detail::StepCells sc;
    std::vector<std::string> unknown, type_errors, repeats;
    for (const auto& [key, value] : obj.items()) {
      const auto t = value_text(value);
      if (lower(key) == "step") {
        step_text = t.value_or(value.dump());
        continue;
      }
      const StepFieldInfo* info = find_step_field(key);
      if (!info) {
        unknown.push_back(fmt::format("'{}'", key));
        continue;
      }
      const auto i = static_cast<std::size_t>(info->field);
      if (!sc.labels[i].empty()) {
        repeats.push_back(
            fmt::format("keys '{}' and '{}' are both {}", sc.labels[i], key, info->csv_column));
        continue;
      }
      sc.labels[i] = key;
      if (t) {
        sc.text[i] = *t;
      } else {
        type_errors.push_back(
            fmt::format("{} must be a number or a string, not {}", key, value.dump()));
      }
    }
    std::optional<unsigned> step;
    if (step_text) {
      auto s = detail::parse_step_number(*step_text);
      if (s) {
        step = *s;
      } else {
        errors.push_back(fmt::format("{}: {}", at, s.error()));
      }
    } else {
      errors.push_back(fmt::format("{}: missing key 'step'", at));
    }
    const std::string where = step ? fmt::format("{} (step {})", at, *step) : at;
    for (const auto& r : repeats) errors.push_back(fmt::format("{}: {}", where, r));
    for (const auto& t : type_errors) errors.push_back(fmt::format("{}: {}", where, t));
    if (!unknown.empty()) {
      errors.push_back(fmt::format("{}: unknown key{} {}: known keys are {}", where,
                                   unknown.size() > 1 ? "s" : "", fmt::join(unknown, ", "),
                                   detail::known_columns()));
    }
    std::vector<std::string_view> missing;
    for (const auto& i : step_fields()) {
      if (sc.labels[static_cast<std::size_t>(i.field)].empty()) missing.push_back(i.csv_column);
    }
    if (!missing.empty()) {
      errors.push_back(fmt::format("{}: missing key{} {}", where, missing.size() > 1 ? "s" : "",
                                   fmt::join(missing, ", ")));
    }
    const auto data = detail::parse_step_cells(sc, where, errors);
    if (step) builder.add(*step, data, at, errors);
  }
  if (builder.empty() && errors.empty()) errors.push_back("\"steps\" is empty: no step to restore");
  if (!errors.empty()) return unexpected(std::move(errors));
  StepTable table = std::move(builder.table());
  table.equipment_name = std::move(meta.equipment_name);
  table.controller_id = meta.controller_id;
  return table;
}

}  // namespace lec6::lec
