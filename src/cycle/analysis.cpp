#include "lec6/cycle/analysis.hpp"

#include <algorithm>
#include <utility>

namespace lec6::cycle {

std::string_view share_name(Share s) noexcept {
  switch (s) {
    case Share::Reads:
      return "reads";
    case Share::Start:
      return "start";
    case Share::Motion:
      return "motion";
    case Share::Seen:
      return "seen";
    case Share::Dwell:
      return "dwell";
    case Share::Wait:
      return "wait";
    case Share::After:
      return "after";
    case Share::Tail:
      return "tail";
  }
  return "?";
}

bool line_share(Share s) noexcept {
  return s == Share::Reads || s == Share::Start || s == Share::Seen || s == Share::After ||
         s == Share::Tail;
}

namespace {

// A motion that reached the controller (a refused one wrote nothing).
bool started(const AxisSpan& a) {
  return a.motion && a.outcome != Outcome::Refused;
}

// Lays the critical path down segment by segment, each from where the last
// ended and none past the cycle's end: whatever the report's times, the
// segments tile [0, cycle time].
class Path {
 public:
  explicit Path(CycleAnalysis& a) : a_(a) {}

  void add(const std::string& step, const std::string& axis, Share share, Duration to,
           Duration bound, StepShare* into) {
    to = std::min(
        {std::max(to, cursor_), std::max(bound, cursor_), std::max(a_.cycle_time, cursor_)});
    if (to == cursor_) return;
    a_.critical_path.push_back({step, axis, share, cursor_, to});
    const Duration d = to - cursor_;
    cursor_ = to;
    bucket(a_.line, a_.motion, a_.program, share) += d;
    if (into) bucket(into->line, into->motion, into->program, share) += d;
  }

 private:
  // Whose time a share is: the line's, the axes' (motion) or the program's.
  static Duration& bucket(Duration& line, Duration& motion, Duration& program, Share share) {
    return line_share(share) ? line : share == Share::Motion ? motion : program;
  }

  CycleAnalysis& a_;
  Duration cursor_{};
};

StepShare step_share(Path& path, const StepReport& s) {
  StepShare out{s.path, s.text, {}, {}, s.start, s.end, {}, {}, {}, {}};
  path.add(s.path, {}, Share::Reads, s.start, s.end, &out);
  const auto last =
      std::max_element(s.axes.begin(), s.axes.end(), [](const auto& x, const auto& y) {
        return x.end < y.end;  // the first of the latest on a tie
      });
  if (last != s.axes.end()) {
    const AxisSpan& c = *last;
    out.critical_axis = c.axis;
    out.critical_member = static_cast<std::size_t>(last - s.axes.begin());
    path.add(s.path, c.axis, Share::Start, c.start, s.end, &out);
    if (c.motion && !started(c)) {  // refused: its checks' reads, nothing moved
      path.add(s.path, c.axis, Share::Start, c.end, s.end, &out);
    } else if (c.motion) {
      if (c.busy_fell_after) {
        path.add(s.path, c.axis, Share::Motion, *c.busy_fell_after, s.end, &out);
        path.add(s.path, c.axis, Share::Seen, c.end, s.end, &out);
      } else {
        path.add(s.path, c.axis, Share::Motion, c.end, s.end, &out);
      }
    } else {
      path.add(s.path, c.axis, c.axis.empty() ? Share::Dwell : Share::Wait, c.end, s.end, &out);
    }
  }
  path.add(s.path, out.critical_axis, Share::After, s.end, s.end, &out);
  std::vector<Duration> starts;
  for (const auto& m : s.axes) {
    if (started(m)) starts.push_back(m.start);
  }
  if (starts.size() > 1) {
    const auto [lo, hi] = std::minmax_element(starts.begin(), starts.end());
    out.start_skew = *hi - *lo;
  }
  return out;
}

AxisUse axis_use(const CycleReport& r, const std::string& axis) {
  AxisUse u{axis, 0, {}, 0};
  std::vector<std::pair<Duration, Duration>> spans;
  for (const auto& s : r.steps) {
    for (const auto& m : s.axes) {
      if (m.axis != axis || !started(m)) continue;
      ++u.motions;
      spans.emplace_back(m.start, std::max(m.start, m.end));
    }
  }
  std::sort(spans.begin(), spans.end());
  Duration covered_to{};
  for (const auto& [from, to] : spans) {  // their union: a wait on the axis may overlap
    const Duration begin = std::max(from, covered_to);
    if (to > begin) u.moving += to - begin;
    covered_to = std::max(covered_to, to);
  }
  if (r.cycle_time > Duration::zero()) {
    u.utilisation = std::chrono::duration<double>(u.moving) / r.cycle_time;
  }
  return u;
}

}  // namespace

CycleAnalysis analyse(const CycleReport& r) {
  CycleAnalysis a;
  a.cycle_time = r.cycle_time;
  Path path(a);
  for (const auto& s : r.steps) {
    a.steps.push_back(step_share(path, s));
    if (const auto& k = a.steps.back().start_skew) {
      a.max_start_skew = std::max(a.max_start_skew.value_or(Duration::zero()), *k);
    }
  }
  path.add({}, {}, Share::Tail, r.cycle_time, r.cycle_time, nullptr);
  std::vector<std::string> names;
  for (const auto& l : r.lines) names.insert(names.end(), l.axes.begin(), l.axes.end());
  for (const auto& s : r.steps) {
    for (const auto& m : s.axes) {
      if (!m.axis.empty() && std::find(names.begin(), names.end(), m.axis) == names.end())
        names.push_back(m.axis);
    }
  }
  for (const auto& n : names) a.axes.push_back(axis_use(r, n));
  for (const auto& l : r.lines) {
    LineLoad load{l.line, l.axes, l.transactions, l.timeouts, {}};
    const bool known = l.busy > Duration::zero() || l.transactions == 0;
    if (known && r.cycle_time > Duration::zero()) {
      load.utilisation = std::chrono::duration<double>(l.busy) / r.cycle_time;
    }
    a.lines.push_back(std::move(load));
  }
  return a;
}

}  // namespace lec6::cycle
