#include "cli/cycle_report.hpp"

#include <fmt/format.h>

#include <map>

#include "lec6/lec/units.hpp"

namespace lec6::cli {

std::string xml_escape(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string format_fault(const InjectedFault& f) {
  return f.step.empty() ? fmt::format("{}: {}", f.fault, f.what)
                        : fmt::format("step {}: {}: {}", f.step, f.fault, f.what);
}

std::string format_step(const cycle::StepReport& step) {
  std::string out = fmt::format("step {}  {}  {:.3f} -> {:.3f} s  {}\n", step.path, step.text,
                                to_seconds(step.start), to_seconds(step.end), step.decision);
  for (const auto& a : step.axes) {
    const std::string at = a.axis.empty() ? "" : lec::format_mm(a.position_001mm) + " mm";
    out += fmt::format("  {:<6} {:.3f} -> {:.3f} s  {:<11} {:>11}  {}\n",
                       a.axis.empty() ? "-" : a.axis, to_seconds(a.start), to_seconds(a.end),
                       cycle::outcome_name(a.outcome), at, a.detail);
  }
  return out;
}

std::string format_end(const cycle::CycleReport& r, bool simulated) {
  std::string out =
      fmt::format("cycle {} in {:.3f} s ({}), {} pass{}\n", r.completed ? "completed" : "ended",
                  to_seconds(r.cycle_time), simulated ? "simulated time on the twin" : "real time",
                  r.iterations, r.iterations == 1 ? "" : "es");
  if (!r.completed) out += fmt::format("  {}\n", r.ended);
  if (!r.stood.empty()) {
    out += "where each axis stood:\n";
    for (const auto& s : r.stood) {
      out +=
          fmt::format("  {:<6} {:>11}  {}\n", s.axis,
                      s.answered ? lec::format_mm(s.position_001mm) + " mm" : "not known", s.how);
    }
  }
  return out;
}

std::string format_analysis(const cycle::CycleAnalysis& a) {
  auto pc = [&](Duration d) {
    return a.cycle_time > Duration::zero() ? 100.0 * to_seconds(d) / to_seconds(a.cycle_time) : 0.0;
  };
  std::map<cycle::Share, Duration> line;
  for (const auto& seg : a.critical_path) {
    if (cycle::line_share(seg.share)) line[seg.share] += seg.to - seg.from;
  }
  std::string parts;
  for (const auto& [share, d] : line) {
    parts += fmt::format("{}{} {:.3f}", parts.empty() ? "" : ", ", cycle::share_name(share),
                         to_seconds(d));
  }
  std::string out = fmt::format(
      "where the time went: motion {:.3f} s ({:.0f} %), the line {:.3f} s ({:.0f} %{}), dwells "
      "and waits {:.3f} s ({:.0f} %)\n",
      to_seconds(a.motion), pc(a.motion), to_seconds(a.line), pc(a.line),
      parts.empty() ? "" : ": " + parts, to_seconds(a.program), pc(a.program));
  for (const auto& l : a.lines) {
    out += fmt::format("  line {}: {} exchanges, busy {}\n", l.line, l.transactions,
                       l.utilisation ? fmt::format("{:.0f} % of the cycle", 100 * *l.utilisation)
                                     : std::string("not known (no wire times)"));
  }
  if (a.max_start_skew) {
    out += fmt::format("  largest start skew in a parallel group: {:.1f} ms\n",
                       to_ms(*a.max_start_skew));
  }
  return out;
}

std::string junit_xml(const std::string& cycle_name, const cycle::CycleReport& r,
                      std::optional<Duration> max_cycle_time) {
  struct Case {
    std::string name;
    std::string failure;  // empty: passed
  };
  std::vector<Case> cases;
  cases.push_back({"the cycle completes", r.completed ? "" : r.ended});
  std::string missed;
  for (const auto& s : r.steps) {
    for (const auto& a : s.axes) {
      if (a.outcome == cycle::Outcome::PushMissed) {
        missed += fmt::format("step {}: {} missed its workpiece ({} mm); ", s.path, a.what,
                              lec::format_mm(a.position_001mm));
      }
    }
  }
  cases.push_back({"every push found its workpiece", missed});
  const bool refused = r.ended.find("interlock:") != std::string::npos;
  cases.push_back({"no interlock refused a step", refused ? r.ended : ""});
  if (max_cycle_time) {
    const bool over = r.cycle_time > *max_cycle_time;
    cases.push_back({fmt::format("the cycle time is under {:.3f} s", to_seconds(*max_cycle_time)),
                     over ? fmt::format("the cycle took {:.3f} s", to_seconds(r.cycle_time)) : ""});
  }
  unsigned failures = 0;
  for (const auto& c : cases) failures += c.failure.empty() ? 0 : 1;
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += fmt::format("<testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" time=\"{:.3f}\">\n",
                     xml_escape(cycle_name), cases.size(), failures, to_seconds(r.cycle_time));
  for (const auto& c : cases) {
    out += fmt::format("  <testcase classname=\"{}\" name=\"{}\"", xml_escape(cycle_name),
                       xml_escape(c.name));
    if (c.failure.empty()) {
      out += "/>\n";
    } else {
      out +=
          fmt::format(">\n    <failure message=\"{}\"/>\n  </testcase>\n", xml_escape(c.failure));
    }
  }
  out += "</testsuite>\n";
  return out;
}

}  // namespace lec6::cli
