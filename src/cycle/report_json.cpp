#include "lec6/cycle/report_json.hpp"

#include <nlohmann/json.hpp>

#include "lec6/clock.hpp"

namespace lec6::cycle {

namespace {

nlohmann::json analysis_json(const CycleAnalysis& a) {
  nlohmann::json path = nlohmann::json::array();
  for (const auto& seg : a.critical_path) {
    path.push_back({{"step", seg.step},
                    {"axis", seg.axis},
                    {"share", share_name(seg.share)},
                    {"from_s", to_seconds(seg.from)},
                    {"to_s", to_seconds(seg.to)}});
  }
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& s : a.steps) {
    nlohmann::json j{{"step", s.step},
                     {"critical_axis", s.critical_axis},
                     {"motion_s", to_seconds(s.motion)},
                     {"line_s", to_seconds(s.line)},
                     {"program_s", to_seconds(s.program)}};
    if (s.start_skew) j["start_skew_s"] = to_seconds(*s.start_skew);
    steps.push_back(std::move(j));
  }
  nlohmann::json axes = nlohmann::json::array();
  for (const auto& u : a.axes) {
    axes.push_back({{"axis", u.axis},
                    {"motions", u.motions},
                    {"moving_s", to_seconds(u.moving)},
                    {"utilisation", u.utilisation}});
  }
  nlohmann::json lines = nlohmann::json::array();
  for (const auto& l : a.lines) {
    lines.push_back({{"line", l.line},
                     {"axes", l.axes},
                     {"transactions", l.transactions},
                     {"timeouts", l.timeouts},
                     {"utilisation", l.utilisation ? nlohmann::json(*l.utilisation) : nullptr}});
  }
  nlohmann::json out{{"motion_s", to_seconds(a.motion)},
                     {"line_s", to_seconds(a.line)},
                     {"program_s", to_seconds(a.program)},
                     {"critical_path", path},
                     {"steps", steps},
                     {"axes", axes},
                     {"lines", lines}};
  out["max_start_skew_s"] =
      a.max_start_skew ? nlohmann::json(to_seconds(*a.max_start_skew)) : nullptr;
  return out;
}

}  // namespace

std::string report_json(const std::string& cycle_name, const CycleReport& r,
                        const CycleAnalysis& analysis, bool simulated,
                        const std::vector<InjectedFault>& faults) {
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& s : r.steps) {
    nlohmann::json axes = nlohmann::json::array();
    for (const auto& a : s.axes) {
      axes.push_back({{"axis", a.axis},
                      {"what", a.what},
                      {"start_s", to_seconds(a.start)},
                      {"end_s", to_seconds(a.end)},
                      {"outcome", outcome_name(a.outcome)},
                      {"position_mm", a.position_001mm / 100.0},
                      {"detail", a.detail}});
      if (a.busy_fell_after && a.busy_fell_by) {
        axes.back()["busy_fell_s"] = {to_seconds(*a.busy_fell_after), to_seconds(*a.busy_fell_by)};
      }
    }
    steps.push_back({{"step", s.path},
                     {"text", s.text},
                     {"start_s", to_seconds(s.start)},
                     {"end_s", to_seconds(s.end)},
                     {"decision", s.decision},
                     {"axes", axes}});
  }
  nlohmann::json stood = nlohmann::json::array();
  for (const auto& s : r.stood) {
    stood.push_back(
        {{"axis", s.axis},
         {"stopped", s.stopped},
         {"position_mm", s.answered ? nlohmann::json(s.position_001mm / 100.0) : nullptr},
         {"how", s.how}});
  }
  nlohmann::json faults_json = nlohmann::json::array();
  for (const auto& f : faults) {
    faults_json.push_back(
        {{"fault", f.fault},
         {"step", f.step.empty() ? nlohmann::json(nullptr) : nlohmann::json(f.step)},
         {"injected", f.injected},
         {"what", f.what}});
  }
  return nlohmann::json{{"cycle", cycle_name},
                        {"completed", r.completed},
                        {"ended", r.ended},
                        {"cycle_time_s", to_seconds(r.cycle_time)},
                        {"simulated", simulated},
                        {"passes", r.iterations},
                        {"steps", steps},
                        {"stood", stood},
                        {"analysis", analysis_json(analysis)},
                        {"faults", faults_json}}
      .dump(2);
}

}  // namespace lec6::cycle
