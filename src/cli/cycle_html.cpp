#include "cli/cycle_html.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cli/cycle_report.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {

namespace {

using cycle::AxisSpan;
using cycle::Outcome;
using cycle::Share;

std::string esc(std::string_view s) {
  return xml_escape(s);
}

std::string secs(Duration d) {
  return fmt::format("{:.3f}", to_seconds(d));
}

std::string percent(Duration part, Duration whole) {
  if (whole <= Duration::zero()) return "-";
  return fmt::format("{:.0f} %", 100.0 * to_seconds(part) / to_seconds(whole));
}

// The bar's class: how the activity ended.
std::string_view outcome_class(const AxisSpan& a) {
  switch (a.outcome) {
    case Outcome::Reached:
    case Outcome::Pushed:
      return "ok";
    case Outcome::Done:
      return a.axis.empty() ? "dwell" : "wait";
    case Outcome::PushMissed:
      return "missed";
    default:
      return "failed";
  }
}

// A time axis step of 1, 2 or 5 × 10^n seconds giving about 10 ticks.
double tick_step(double seconds) {
  const double raw = std::max(seconds, 1e-3) / 10;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (raw <= m * mag) return m * mag;
  }
  return 10 * mag;
}

constexpr double kLabel = 90;  // px: the lane names
constexpr double kPlot = 1000;
constexpr double kLane = 28;
constexpr double kTop = 30;  // the step labels

class Gantt {
 public:
  Gantt(const cycle::CycleReport& r, const cycle::CycleAnalysis& a) : r_(r), a_(a) {
    for (const auto& u : a.axes) lanes_.push_back(u.axis);
    for (const auto& s : r.steps) {
      for (const auto& m : s.axes) has_dwell_ |= m.axis.empty();
    }
    if (has_dwell_) lanes_.push_back("");
    total_ = std::max(to_seconds(r.cycle_time), 1e-3);
  }

  std::string svg() const {
    const double height = kTop + kLane * (lanes_.size() + 1) + 24;
    std::string out = fmt::format(
        "<svg id=\"gantt\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
        "viewBox=\"0 0 {} {}\" role=\"img\" aria-label=\"Gantt chart of the cycle\">\n",
        kLabel + kPlot + 10, height, kLabel + kPlot + 10, height);
    for (std::size_t i = 0; i <= lanes_.size(); ++i) {
      const std::string name =
          i == lanes_.size() ? "line" : (lanes_[i].empty() ? "dwell" : lanes_[i]);
      out += fmt::format("<text class=\"lane\" x=\"4\" y=\"{:.1f}\">{}</text>\n",
                         y(i) + kLane * 0.62, esc(name));
    }
    out += ticks(height - 20);
    for (std::size_t i = 0; i < r_.steps.size(); ++i) {
      const auto& s = r_.steps[i];
      const double x0 = x(s.start);
      out += fmt::format(
          "<line class=\"step\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2:.1f}\"/>\n", x0,
          kTop - 12, height - 22);
      if (x(s.end) - x0 > 8 + 6 * s.path.size()) {
        out += fmt::format("<text class=\"steplabel\" x=\"{:.1f}\" y=\"{}\">{}</text>\n", x0 + 2,
                           kTop - 14, esc(s.path));
      }
      for (std::size_t k = 0; k < s.axes.size(); ++k) {
        out += bar(s.path, s.axes[k], a_.steps.at(i).critical_member == k);
      }
    }
    for (const auto& seg : a_.critical_path) {
      if (!cycle::line_share(seg.share)) continue;
      out += fmt::format(
          "<rect class=\"line {}\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{}\">"
          "<title>{} {}: {} -> {} s (the line)</title></rect>\n",
          cycle::share_name(seg.share), x(seg.from), y(lanes_.size()) + 5, width(seg.from, seg.to),
          kLane - 10, seg.step.empty() ? "end" : "step " + esc(seg.step),
          cycle::share_name(seg.share), secs(seg.from), secs(seg.to));
    }
    out += "</svg>\n";
    return out;
  }

 private:
  double x(Duration t) const {
    return kLabel + kPlot * std::clamp(to_seconds(t) / total_, 0.0, 1.0);
  }
  double width(Duration from, Duration to) const { return std::max(1.0, x(to) - x(from)); }
  double y(std::size_t lane) const { return kTop + kLane * lane; }

  std::string ticks(double at) const {
    std::string out;
    const double step = tick_step(total_);
    for (double t = 0; t <= total_ + 1e-9; t += step) {
      const double px = kLabel + kPlot * t / total_;
      out += fmt::format(
          "<line class=\"tick\" x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2:.1f}\"/>"
          "<text class=\"ticklabel\" x=\"{0:.1f}\" y=\"{3:.1f}\">{4:g} s</text>\n",
          px, kTop, at - 4, at + 12, std::round(t * 1000) / 1000);
    }
    return out;
  }

  std::string bar(const std::string& step, const AxisSpan& m, bool critical) const {
    const auto lane = std::find(lanes_.begin(), lanes_.end(), m.axis) - lanes_.begin();
    std::string title = fmt::format("step {} {}: {}, {} -> {} s, {}", step, m.axis, m.what,
                                    secs(m.start), secs(m.end), cycle::outcome_name(m.outcome));
    if (!m.detail.empty()) title += "; " + m.detail;
    // A wait shares its axis's lane with the move it watches: drawn as a
    // thin bar at the lane's foot, under the move's.
    const bool wait = !m.motion && !m.axis.empty();
    std::string out = fmt::format(
        "<rect class=\"bar {}{}\" data-step=\"{}\" data-axis=\"{}\" x=\"{:.1f}\" y=\"{:.1f}\" "
        "width=\"{:.1f}\" height=\"{}\"><title>{}</title></rect>\n",
        outcome_class(m), critical ? " critical" : "", esc(step), esc(m.axis), x(m.start),
        y(lane) + (wait ? kLane - 9 : 3), width(m.start, m.end), wait ? 6 : kLane - 6, esc(title));
    if (m.busy_fell_after && m.busy_fell_by) {  // where BUSY fell: between two polls
      out += fmt::format(
          "<rect class=\"fell\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"4\">"
          "<title>BUSY fell between {} and {} s</title></rect>\n",
          x(*m.busy_fell_after), y(lane) + kLane - 7, width(*m.busy_fell_after, *m.busy_fell_by),
          secs(*m.busy_fell_after), secs(*m.busy_fell_by));
    }
    return out;
  }

  const cycle::CycleReport& r_;
  const cycle::CycleAnalysis& a_;
  std::vector<std::string> lanes_;  // the axes, then "" for the dwells
  bool has_dwell_ = false;
  double total_ = 1;
};

constexpr std::string_view kStyle = R"(
body { font: 14px/1.4 system-ui, sans-serif; margin: 24px; color: #1d2330; max-width: 1120px; }
h1 { font-size: 20px; margin: 0 0 4px; }
.sub { color: #5b6475; margin-bottom: 16px; }
.ended { padding: 8px 12px; border-radius: 4px; margin-bottom: 12px; }
.ended.ok { background: #e5f4ea; } .ended.bad { background: #fbe6e4; }
.figures { display: flex; flex-wrap: wrap; gap: 12px; margin: 12px 0 18px; }
.figure { border: 1px solid #d6dae3; border-radius: 6px; padding: 8px 12px; min-width: 150px; }
.figure b { display: block; font-size: 20px; }
.figure span { color: #5b6475; font-size: 12px; }
svg text { font-size: 11px; fill: #1d2330; }
svg .lane { font-weight: 600; }
svg .tick { stroke: #e3e6ec; } svg .step { stroke: #9aa3b5; stroke-dasharray: 3 3; }
svg .bar.ok { fill: #6aa5e8; } svg .bar.wait { fill: #c3cad8; } svg .bar.dwell { fill: #e8c76a; }
svg .bar.missed { fill: #f0a04b; } svg .bar.failed { fill: #e0625a; }
svg .bar.critical { stroke: #1d2330; stroke-width: 2; }
svg .fell { fill: #1d2330; opacity: .6; }
svg .line { fill: #b48ad8; } svg .line.seen { fill: #d9c4ec; }
table { border-collapse: collapse; margin: 8px 0 20px; }
th, td { border-bottom: 1px solid #e3e6ec; padding: 3px 10px; text-align: left; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
.legend span { display: inline-block; width: 12px; height: 12px; margin: 0 4px 0 14px; vertical-align: -2px; }
)";

std::string figure(const std::string& value, const std::string& what, std::string_view id) {
  return fmt::format("<div class=\"figure\" data-figure=\"{}\"><b>{}</b><span>{}</span></div>\n",
                     id, esc(value), esc(what));
}

std::string step_rows(const cycle::CycleReport& r, const cycle::CycleAnalysis& a) {
  std::string out;
  for (std::size_t i = 0; i < a.steps.size(); ++i) {
    const auto& s = a.steps[i];
    out += fmt::format(
        "<tr><td>{}</td><td>{}</td><td class=n>{}</td><td class=n>{}</td><td>{}</td>"
        "<td class=n>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{}</td><td>{}</td>"
        "</tr>\n",
        esc(s.step), esc(s.text), secs(s.start), secs(s.end), esc(s.critical_axis), secs(s.motion),
        secs(s.line), secs(s.program),
        s.start_skew ? fmt::format("{:.1f} ms", to_ms(*s.start_skew)) : "",
        esc(r.steps[i].decision));
  }
  return out;
}

}  // namespace

std::string cycle_html(const CycleReportPage& page, const cycle::CycleReport& r,
                       const cycle::CycleAnalysis& a) {
  std::string out = "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n";
  out += fmt::format("<title>Cycle {} — lec cycle report</title>\n<style>{}</style></head><body>\n",
                     esc(page.cycle), kStyle);
  out += fmt::format("<h1>Cycle {}</h1>\n<div class=\"sub\">{} on {} ({})</div>\n", esc(page.cycle),
                     esc(page.file), esc(page.where),
                     page.simulated ? "simulated time on the twin" : "real time");
  out += fmt::format("<div class=\"ended {}\" id=\"ended\">{}</div>\n", r.completed ? "ok" : "bad",
                     esc(r.completed ? fmt::format("Completed: {} pass{}", r.iterations,
                                                   r.iterations == 1 ? "" : "es")
                                     : "Not completed: " + r.ended));
  out += "<div class=\"figures\">\n";
  out += figure(secs(r.cycle_time) + " s", "cycle time", "cycle");
  out += figure(secs(a.motion) + " s",
                "motion on the critical path (" + percent(a.motion, r.cycle_time) + ")", "motion");
  out += figure(secs(a.line) + " s", "the line's share (" + percent(a.line, r.cycle_time) + ")",
                "line");
  out += figure(secs(a.program) + " s",
                "dwells and waits (" + percent(a.program, r.cycle_time) + ")", "program");
  if (a.max_start_skew) {
    out += figure(fmt::format("{:.1f} ms", to_ms(*a.max_start_skew)),
                  "largest start skew in a group", "skew");
  }
  for (const auto& l : a.lines) {
    out += figure(l.utilisation ? fmt::format("{:.0f} %", 100 * *l.utilisation) : "not known",
                  "line busy: " + l.line, "utilisation");
  }
  out += "</div>\n<h2>Gantt chart</h2>\n";
  out += Gantt(r, a).svg();
  out +=
      "<div class=\"legend\"><span style=\"background:#6aa5e8\"></span>motion"
      "<span style=\"background:#c3cad8\"></span>wait<span "
      "style=\"background:#e8c76a\"></span>dwell"
      "<span style=\"background:#f0a04b\"></span>push missed<span "
      "style=\"background:#e0625a\"></span>"
      "alarm, timeout, stop, refused<span style=\"background:#b48ad8\"></span>the line on the "
      "critical path (reads, starts, after, tail)<span style=\"background:#d9c4ec\"></span>end of "
      "motion "
      "being seen (BUSY's fall, the poll)<span style=\"border:2px solid #1d2330;background:#fff\">"
      "</span>critical path</div>\n";
  out +=
      "<h2>Steps</h2>\n<table id=\"steps\"><tr><th>step</th><th>what</th><th>start s</th>"
      "<th>end s</th><th>critical axis</th><th>motion s</th><th>line s</th><th>dwell/wait s</th>"
      "<th>start skew</th><th>then</th></tr>\n";
  out += step_rows(r, a) + "</table>\n";
  out +=
      "<h2>Axes</h2>\n<table id=\"axes\"><tr><th>axis</th><th>motions</th><th>moving s</th>"
      "<th>of the cycle</th></tr>\n";
  for (const auto& u : a.axes) {
    out += fmt::format(
        "<tr><td>{}</td><td class=n>{}</td><td class=n>{}</td><td class=n>{:.0f} %"
        "</td></tr>\n",
        esc(u.axis), u.motions, secs(u.moving), 100 * u.utilisation);
  }
  out +=
      "</table>\n<h2>Lines</h2>\n<table id=\"lines\"><tr><th>line</th><th>axes</th>"
      "<th>exchanges</th><th>timeouts</th><th>busy</th></tr>\n";
  for (const auto& l : a.lines) {
    std::string axes;
    for (const auto& n : l.axes) axes += (axes.empty() ? "" : ", ") + n;
    out += fmt::format(
        "<tr><td>{}</td><td>{}</td><td class=n>{}</td><td class=n>{}</td>"
        "<td class=n>{}</td></tr>\n",
        esc(l.line), esc(axes), l.transactions, l.timeouts,
        l.utilisation ? fmt::format("{:.0f} %", 100 * *l.utilisation) : "not known");
  }
  out += "</table>\n";
  if (!r.stood.empty()) {
    out += "<h2>Where each axis stood</h2>\n<table id=\"stood\">\n";
    for (const auto& s : r.stood) {
      out += fmt::format("<tr><td>{}</td><td class=n>{} mm</td><td>{}</td></tr>\n", esc(s.axis),
                         lec::format_mm(s.position_001mm), esc(s.how));
    }
    out += "</table>\n";
  }
  out += "</body></html>\n";
  return out;
}

}  // namespace lec6::cli
