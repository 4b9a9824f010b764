#include "config_history.hpp"

namespace lec6::serve::history {

std::optional<HistoryConfig> read_history(const Reader& r, const YAML::Node& n) {
  if (!n) return std::nullopt;
  if (n.IsScalar() && !r.get<bool>(n, "history", true)) return std::nullopt;
  if (!n.IsMap() && !n.IsScalar())
    r.fail(n, "history", "expected false, true or a map (state_dir:, retention, drift)");
  if (n.IsScalar()) return HistoryConfig{};  // `history: true`: the default directory
  r.keys(n, "history",
         {"state_dir", "max_age_days", "max_size_mb", "queue", "drift_threshold_pct",
          "drift_baseline_moves", "drift_tolerance_mm", "services"});
  HistoryConfig h;
  // Without state_dir: the default directory (state_dir.hpp, issue 32).
  if (n["state_dir"]) {
    h.state_dir = r.get<std::string>(n["state_dir"], "history.state_dir", "");
    if (h.state_dir.empty()) r.fail(n["state_dir"], "history.state_dir", "empty");
  }
  h.max_age_days = r.number(n["max_age_days"], "history.max_age_days", 365, 0.001, 36500);
  h.max_size_mb = r.number(n["max_size_mb"], "history.max_size_mb", 100, 0.1, 1e6);
  h.queue = static_cast<unsigned>(
      r.integer(n["queue"], "history.queue", 4096, 16, 1'000'000, "16 to 1000000 records"));
  h.drift_threshold_pct =
      r.number(n["drift_threshold_pct"], "history.drift_threshold_pct", 10, 1, 1000);
  h.drift_baseline_moves = static_cast<unsigned>(r.integer(
      n["drift_baseline_moves"], "history.drift_baseline_moves", 20, 5, 10000, "5 to 10000"));
  h.drift_tolerance_mm =
      r.number(n["drift_tolerance_mm"], "history.drift_tolerance_mm", 0.5, 0, 1000);
  if (const auto s = n["services"]) {
    if (!s.IsSequence()) r.fail(s, "history.services", "expected a list of services");
    for (std::size_t i = 0; i < s.size(); ++i) {
      const std::string path = fmt::format("history.services[{}]", i);
      r.keys(s[i], path, {"what", "every_km", "every_moves", "every_hours"});
      HistoryConfig::Service sv;
      sv.what = r.get<std::string>(s[i]["what"], path + ".what", "");
      if (sv.what.empty()) r.fail(s[i], path + ".what", "every service needs a what: (lubricate)");
      int given = 0;
      if (s[i]["every_km"]) {
        sv.every_km = r.number(s[i]["every_km"], path + ".every_km", 0, 0.001, 1e9);
        ++given;
      }
      if (s[i]["every_moves"]) {
        sv.every_moves = r.number(s[i]["every_moves"], path + ".every_moves", 0, 1, 1e15);
        ++given;
      }
      if (s[i]["every_hours"]) {
        sv.every_hours = r.number(s[i]["every_hours"], path + ".every_hours", 0, 0.001, 1e9);
        ++given;
      }
      if (given != 1) {
        r.fail(s[i], path, "give exactly one of every_km, every_moves and every_hours");
      }
      h.services.push_back(sv);
    }
  }
  return h;
}

}  // namespace lec6::serve::history
