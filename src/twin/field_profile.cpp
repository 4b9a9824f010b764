// Field profiles (field_profile.hpp): YAML/JSON → the twin's configs, one
// table of keys with their ranges, every error with file, line and rule.

#include "lec6/twin/field_profile.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <vector>

#include "lec6/lec/equipment_name.hpp"
#include "lec6/modbus/timing.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::twin {
namespace {

// What one key holds and where it goes.
struct Key {
  const char* section;
  const char* name;
  enum Kind { Number, Integer, Flag, Text } kind;
  double min = 0, max = 0;  // Number, Integer
  const char* unit = "";
  std::function<void(FieldProfile&, const YAML::Node&)> set;
};

double number_of(const YAML::Node& n) {
  return n.as<double>();
}

Duration ms_of(const YAML::Node& n) {
  return to_duration(FractionalMilliseconds(n.as<double>()));
}

const std::vector<Key>& keys() {
  using P = FieldProfile;
  using N = YAML::Node;
  static const std::vector<Key> k = {
      {"actuator", "stroke_min_mm", Key::Number, -1e6, 0, "mm",
       [](P& p, const N& n) { p.actuator.stroke_min_mm = number_of(n); }},
      {"actuator", "stroke_max_mm", Key::Number, 0, 1e6, "mm",
       [](P& p, const N& n) { p.actuator.stroke_max_mm = number_of(n); }},
      {"actuator", "max_speed_mm_s", Key::Number, 1, 65535, "mm/s",
       [](P& p, const N& n) { p.actuator.max_speed_mm_s = number_of(n); }},
      {"actuator", "max_accel_mm_s2", Key::Number, 1, 65535, "mm/s²",
       [](P& p, const N& n) { p.actuator.max_accel_mm_s2 = number_of(n); }},
      {"actuator", "jog_speed_mm_s", Key::Number, 1, 65535, "mm/s",
       [](P& p, const N& n) { p.actuator.jog_speed_mm_s = number_of(n); }},
      {"actuator", "origin_speed_mm_s", Key::Number, 1, 65535, "mm/s",
       [](P& p, const N& n) { p.actuator.origin_speed_mm_s = number_of(n); }},
      {"actuator", "initial_position_mm", Key::Number, -1e6, 1e6, "mm",
       [](P& p, const N& n) { p.actuator.initial_position_mm = number_of(n); }},
      {"actuator", "workpiece_mm", Key::Number, -1e6, 1e6, "mm",
       [](P& p, const N& n) { p.actuator.workpiece_mm = number_of(n); }},
      {"actuator", "svre_delay_ms", Key::Number, 0, 10000, "ms",
       [](P& p, const N& n) { p.actuator.svre_delay = ms_of(n); }},
      {"actuator", "stall_alarm_delay_ms", Key::Number, 0, 60000, "ms",
       [](P& p, const N& n) { p.actuator.stall_alarm_delay = ms_of(n); }},
      {"actuator", "equipment_name", Key::Text, 0, 0, "",
       [](P& p, const N& n) { p.actuator.equipment_name = n.as<std::string>(); }},
      {"actuator", "busy_delay_ms", Key::Number, 0, 10000, "ms",
       [](P& p, const N& n) { p.actuator.busy_delay = ms_of(n); }},
      {"actuator", "busy_min_ms", Key::Number, 0, 10000, "ms",
       [](P& p, const N& n) { p.actuator.busy_min = ms_of(n); }},
      {"actuator", "target_update_late", Key::Flag, 0, 0, "",
       [](P& p, const N& n) { p.actuator.target_update_late = n.as<bool>(); }},
      {"actuator", "origin_accel_mm_s2", Key::Number, 1, 65535, "mm/s²",
       [](P& p, const N& n) { p.actuator.origin_accel_mm_s2 = number_of(n); }},
      {"actuator", "homing_direction", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.actuator.homing_direction = n.as<std::string>() == "max_end"
                                           ? sim::ActuatorConfig::HomingDirection::MaxEnd
                                           : sim::ActuatorConfig::HomingDirection::MinEnd;
       }},
      {"actuator", "seton_on_rehome", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.actuator.seton_on_rehome = n.as<std::string>() == "clear"
                                          ? sim::ActuatorConfig::SetonOnRehome::Clear
                                          : sim::ActuatorConfig::SetonOnRehome::Keep;
       }},
      {"actuator", "reset_cancels_homing", Key::Flag, 0, 0, "",
       [](P& p, const N& n) { p.actuator.reset_cancels_homing = n.as<bool>(); }},
      {"actuator", "retarget", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.actuator.retarget = n.as<std::string>() == "stop_then_start"
                                   ? sim::ActuatorConfig::Retarget::StopThenStart
                                   : sim::ActuatorConfig::Retarget::Replan;
       }},
      {"actuator", "alarm_polarity", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.actuator.alarm_polarity = n.as<std::string>() == "active-low"
                                         ? sim::ActuatorConfig::AlarmPolarity::ActiveLow
                                         : sim::ActuatorConfig::AlarmPolarity::ActiveHigh;
       }},
      {"actuator", "setup_left_high", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.actuator.setup_left_high = n.as<std::string>() == "refuses_starts"
                                          ? sim::ActuatorConfig::SetupLeftHigh::RefusesStarts
                                          : sim::ActuatorConfig::SetupLeftHigh::Ignored;
       }},
      {"actuator", "wear_pct_per_m", Key::Number, 0, 1000, "% per metre",
       [](P& p, const N& n) { p.actuator.wear_pct_per_m = number_of(n); }},
      {"actuator", "friction_thrust_pct", Key::Number, 0, 300, "%",
       [](P& p, const N& n) { p.actuator.friction_thrust_pct = number_of(n); }},
      {"actuator", "accel_thrust_pct", Key::Number, 0, 300, "%",
       [](P& p, const N& n) { p.actuator.accel_thrust_pct = number_of(n); }},
      {"line", "baud", Key::Integer, 9600, 230400, "",
       [](P& p, const N& n) { p.line.line.baud = n.as<uint32_t>(); }},
      {"line", "silent_interval", Key::Integer, 1, 100, "",
       [](P& p, const N& n) { p.line.line.silent_interval_k = n.as<unsigned>(); }},
      {"line", "delay_ms", Key::Number, 0, 1000, "ms",
       [](P& p, const N& n) { p.line.line.delay_td = ms_of(n); }},
      {"line", "timing", Key::Text, 0, 0, "",
       [](P& p, const N& n) {
         p.line.timing = n.as<std::string>() == "fast" ? sim::Timing::Fast : sim::Timing::Real;
       }},
      {"line", "noise_rate", Key::Number, 0, 1e9, "bytes/s",
       [](P& p, const N& n) { p.faults.noise_rate = number_of(n); }},
      {"faults", "seed", Key::Integer, 0, 9.2e18, "",
       [](P& p, const N& n) { p.faults.seed = n.as<uint64_t>(); }},
      {"faults", "drop_rate", Key::Number, 0, 1, "",
       [](P& p, const N& n) { p.faults.drop = number_of(n); }},
      {"faults", "corrupt_rate", Key::Number, 0, 1, "",
       [](P& p, const N& n) { p.faults.corrupt = number_of(n); }},
      {"faults", "garbage_rate", Key::Number, 0, 1, "",
       [](P& p, const N& n) { p.faults.garbage = number_of(n); }},
      {"faults", "delay_rate", Key::Number, 0, 1, "",
       [](P& p, const N& n) { p.faults.delay = number_of(n); }},
      {"faults", "extra_delay_ms", Key::Number, 0, 60000, "ms",
       [](P& p, const N& n) { p.faults.extra_delay = ms_of(n); }},
  };
  return k;
}

// The values a text key takes (none listed: any text the key checks itself).
const std::vector<std::string>* choices(std::string_view key) {
  static const std::map<std::string, std::vector<std::string>, std::less<>> c = {
      {"timing", {"real", "fast"}},
      {"homing_direction", {"min_end", "max_end"}},
      {"seton_on_rehome", {"keep", "clear"}},
      {"retarget", {"replan", "stop_then_start"}},
      {"alarm_polarity", {"active-high", "active-low"}},
      {"setup_left_high", {"ignored", "refuses_starts"}},
  };
  const auto it = c.find(key);
  return it == c.end() ? nullptr : &it->second;
}

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& at, const std::string& path,
                         const std::string& rule) const {
    const YAML::Mark m = at.IsDefined() ? at.Mark() : YAML::Mark::null_mark();
    const std::string where =
        m.line >= 0 ? fmt::format("{}:{}", source_, m.line + 1) : std::string(source_);
    throw ProfileError(path.empty() ? fmt::format("{}: {}", where, rule)
                                    : fmt::format("{}: {}: {}", where, path, rule));
  }

  void check(const Key& k, const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) fail(n, path, "expected a single value");
    const std::string text = n.Scalar();
    switch (k.kind) {
      case Key::Flag:
        try {
          (void)n.as<bool>();
        } catch (const YAML::Exception&) {
          fail(n, path, fmt::format("'{}' is not true or false", text));
        }
        return;
      case Key::Text:
        if (const auto* allowed = choices(k.name);
            allowed && std::find(allowed->begin(), allowed->end(), text) == allowed->end()) {
          std::string list;
          for (const auto& c : *allowed) list += (list.empty() ? "" : " or ") + c;
          fail(n, path, fmt::format("'{}' is not {}", text, list));
        }
        if (std::string_view(k.name) == "equipment_name") {
          if (auto name = lec::EquipmentName::make(text); !name) fail(n, path, name.error());
        }
        return;
      case Key::Integer: {
        long double v = 0;
        try {
          v = n.as<long double>();
        } catch (const YAML::Exception&) {
          fail(n, path, fmt::format("'{}' is not a whole number", text));
        }
        if (v != std::floor(v) || v < k.min || v > k.max)
          fail(n, path, fmt::format("{} is not a whole number from {} to {}", text, k.min, k.max));
        if (std::string_view(k.name) == "baud" && !modbus::is_supported_baud(n.as<uint32_t>()))
          fail(n, path,
               fmt::format("{} is not a baud rate (9600 19200 38400 57600 115200 230400)", text));
        return;
      }
      case Key::Number: {
        double v = 0;
        try {
          v = n.as<double>();
        } catch (const YAML::Exception&) {
          fail(n, path, fmt::format("'{}' is not a number{}", text, unit(k)));
        }
        if (!std::isfinite(v) || v < k.min || v > k.max)
          fail(n, path, fmt::format("{} is outside {} to {}{}", text, k.min, k.max, unit(k)));
        return;
      }
    }
  }

 private:
  static std::string unit(const Key& k) { return *k.unit ? std::string(" ") + k.unit : ""; }
  std::string source_;
};

std::string known_in(std::string_view section) {
  std::string out;
  for (const Key& k : keys()) {
    if (section == k.section) out += (out.empty() ? "" : ", ") + std::string(k.name);
  }
  return out;
}

void read_section(const Reader& r, const YAML::Node& map, const std::string& section,
                  FieldProfile& p) {
  if (!map.IsMap()) r.fail(map, section, "expected a map of settings");
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>();
    const std::string path = section + "." + key;
    const Key* spec = nullptr;
    for (const Key& k : keys()) {
      if (section == k.section && key == k.name) spec = &k;
    }
    if (!spec)
      r.fail(kv.first, path, fmt::format("unknown key (known here: {})", known_in(section)));
    r.check(*spec, kv.second, path);
    spec->set(p, kv.second);
    p.given.insert(path);
  }
}

}  // namespace

FieldProfile default_profile() {
  FieldProfile p;
  p.name = "default";
  p.actuator = sim::default_config();
  return p;
}

FieldProfile ideal_profile() {
  FieldProfile p;
  p.name = "ideal";
  p.actuator = sim::ideal_config();
  return p;
}

std::string field_profile_keys() {
  return fmt::format("actuator: {}\nline: {}\nfaults: {}", known_in("actuator"), known_in("line"),
                     known_in("faults"));
}

FieldProfile parse_field_profile(std::string_view text, const std::string& source,
                                 const FieldProfile& defaults) {
  const Reader r(source);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::ParserException& e) {
    throw ProfileError(fmt::format("{}:{}: not YAML or JSON: {}", source, e.mark.line + 1, e.msg));
  }
  FieldProfile p = defaults;
  p.given.clear();
  p.name.clear();  // the file's (or its stem), not the base's
  p.description.clear();
  if (!root.IsDefined() || root.IsNull()) return p;  // an empty profile changes nothing
  if (!root.IsMap())
    r.fail(root, "", "expected a map with name, description, actuator, line, faults");
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (key == "name" || key == "description") {
      if (!kv.second.IsScalar()) r.fail(kv.second, key, "expected text");
      (key == "name" ? p.name : p.description) = kv.second.as<std::string>();
    } else if (key == "actuator" || key == "line" || key == "faults") {
      read_section(r, kv.second, key, p);
    } else {
      r.fail(kv.first, key, "unknown key (known: name, description, actuator, line, faults)");
    }
  }
  // Rules between keys (stroke and initial position, …): the twin's own check.
  if (auto problems = sim::validate(p.actuator); !problems.empty()) {
    std::string all;
    for (const auto& m : problems) all += (all.empty() ? "" : "; ") + m;
    throw ProfileError(fmt::format("{}: actuator: {}", source, all));
  }
  return p;
}

FieldProfile named_profile(const std::string& name) {
  if (name == "default") return default_profile();
  if (name == "ideal") return ideal_profile();
  return load_field_profile(name, default_profile());
}

FieldProfile load_field_profile(const std::filesystem::path& path, const FieldProfile& defaults) {
  std::ifstream in(path);
  if (!in) throw ProfileError(fmt::format("{}: cannot read the profile", path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  FieldProfile p = parse_field_profile(text.str(), path.string(), defaults);
  if (p.name.empty()) p.name = path.stem().string();
  return p;
}

}  // namespace lec6::twin
