// `lec follow`: the axis as a follower of streamed positions (issue 12).
//
// Input: one setpoint per line, mm ("150.25") or a JSON object
// ({"position_mm": 150.25}); empty lines and lines starting with # are
// skipped. A live stream (pipe, terminal, FIFO) is *followed*: whenever the
// line is free, the newest setpoint is applied and the ones it superseded
// are dropped as stale, so there is never a backlog. A regular file is a
// recorded trajectory: every setpoint in order, each as soon as the line
// allows. At the end of the input the last setpoint's move is waited for
// and reported like `lec move`; Ctrl-C stops the axis (exit 130).

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <deque>

#include "cli/app.hpp"
#include "cli/duration_option.hpp"
#include "cli/move_report.hpp"
#include "lec6/client/follower.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {
namespace {

struct FollowArgs {
  std::string file = "-";
  std::string speed, accel, decel, in_position;
  unsigned check_every = 8;
  Duration timeout = std::chrono::seconds(60);
};

struct Counts {
  uint64_t received = 0, dropped = 0, repeated = 0;
};

// One setpoint line → 0.01 mm. Throws UsageError naming the line.
int32_t parse_setpoint(const std::string& text, uint64_t line_no) {
  auto bad = [&](const std::string& why) {
    return UsageError(fmt::format("input line {}: '{}': {}", line_no, text, why));
  };
  if (text.front() == '{') {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception&) {
      throw bad("not a JSON object");
    }
    if (!j.contains("position_mm") || !j["position_mm"].is_number())
      throw bad("a JSON setpoint needs \"position_mm\": a number of mm");
    const double mm = j["position_mm"].get<double>();
    const double hundredths = std::round(mm * 100.0);
    if (!std::isfinite(mm) || std::abs(mm * 100.0 - hundredths) > 1e-6 ||
        std::abs(hundredths) > 2147483647.0)
      throw bad("position_mm must have at most two decimals and fit ±21474836.47 mm");
    return static_cast<int32_t>(hundredths);
  }
  const auto v = lec::parse_field(lec::StepField::Position, text);
  if (!v) throw bad(v.error());
  return static_cast<int32_t>(*v);
}

class Input {
 public:
  explicit Input(const std::string& path) {
    if (path != "-") {
      fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      if (fd_ < 0) throw CommandFailed(kFailure, fmt::format("cannot read {}", path));
      owned_ = true;
    }
    struct stat st {};
    recorded_ = ::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode);
  }
  ~Input() {
    if (owned_) ::close(fd_);
  }
  Input(const Input&) = delete;
  Input& operator=(const Input&) = delete;

  bool recorded() const { return recorded_; }
  bool eof() const { return eof_ && queue_.empty(); }

  // Reads what is available now (waiting at most `wait_ms` for the first
  // byte) and returns the setpoint to apply next, if any.
  std::optional<int32_t> next(int wait_ms, Counts& counts) {
    if (queue_.empty() && !eof_) fill(wait_ms, counts);
    if (queue_.empty()) return std::nullopt;
    if (!recorded_) {  // follow: the newest wins
      counts.dropped += queue_.size() - 1;
      const int32_t v = queue_.back();
      queue_.clear();
      return v;
    }
    const int32_t v = queue_.front();
    queue_.pop_front();
    return v;
  }

 private:
  void fill(int wait_ms, Counts& counts) {
    pollfd p{fd_, POLLIN, 0};
    for (int timeout = wait_ms;; timeout = 0) {
      if (::poll(&p, 1, timeout) <= 0) return;  // nothing (more) now, or EINTR (Ctrl-C)
      char buf[4096];
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      if (n <= 0) {
        if (n == 0 || (errno != EINTR && errno != EAGAIN)) finish_input(counts);
        return;
      }
      take(std::string_view(buf, static_cast<std::size_t>(n)), counts);
      if (recorded_ && !queue_.empty()) return;  // a trajectory: read as it is played
    }
  }

  void take(std::string_view bytes, Counts& counts) {
    partial_.append(bytes);
    for (auto nl = partial_.find('\n'); nl != std::string::npos; nl = partial_.find('\n')) {
      line(partial_.substr(0, nl), counts);
      partial_.erase(0, nl + 1);
    }
  }

  void line(std::string text, Counts& counts) {
    ++line_no_;
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
    const auto b = text.find_first_not_of(" \t");
    if (b == std::string::npos || text[b] == '#') return;
    queue_.push_back(parse_setpoint(text.substr(b), line_no_));
    ++counts.received;
  }

  void finish_input(Counts& counts) {
    if (!partial_.empty()) line(std::exchange(partial_, {}), counts);
    eof_ = true;
  }

  int fd_ = STDIN_FILENO;
  bool owned_ = false;
  bool recorded_ = false;
  bool eof_ = false;
  uint64_t line_no_ = 0;
  std::string partial_;
  std::deque<int32_t> queue_;
};

std::optional<uint16_t> u16(lec::StepField f, const std::string& text) {
  if (text.empty()) return std::nullopt;
  auto v = lec::parse_field(f, text);
  if (!v) throw UsageError(v.error());
  return static_cast<uint16_t>(*v);
}

void report(const Session& s, const Counts& c, uint64_t applied, Duration took,
            const std::optional<client::MoveResult>& last) {
  const double secs = to_seconds(took);
  const double rate = secs > 0 ? static_cast<double>(applied) / secs : 0.0;
  if (s.json()) {
    nlohmann::json j{{"received", c.received}, {"applied", applied}, {"dropped", c.dropped},
                     {"repeated", c.repeated}, {"seconds", secs},    {"setpoints_per_s", rate}};
    j["final"] = last ? move_json(*last) : nlohmann::json(nullptr);
    print_json(j);
  } else {
    fmt::print(stderr,
               "followed {} setpoints in {:.2f} s: {} applied ({:.1f}/s), {} dropped as stale, {} "
               "repeated\n",
               c.received, secs, applied, rate, c.dropped, c.repeated);
    if (last && last->succeeded()) fmt::print("{}\n", last->describe());
  }
}

void run_follow(Session& s, const FollowArgs& a) {
  client::FollowOptions o;
  o.check_every = a.check_every;
  o.move.speed_mm_s = u16(lec::StepField::Speed, a.speed);
  o.move.acceleration_mm_s2 = u16(lec::StepField::Acceleration, a.accel);
  o.move.deceleration_mm_s2 = u16(lec::StepField::Deceleration, a.decel);
  if (!a.in_position.empty()) {
    auto v = lec::parse_field(lec::StepField::InPosition, a.in_position);
    if (!v) throw UsageError(v.error());
    o.move.in_position_001mm = static_cast<int32_t>(*v);
  }
  Input in(a.file);
  auto& axis = s.axis();
  client::Follower follower(axis, o);
  Counts counts;
  std::optional<int32_t> last_applied;
  const TimePoint began = s.client().clock().now();
  try {
    int wait_ms = 100;  // before the first setpoint, and while idle
    while (!g_interrupted) {
      if (const auto p = in.next(wait_ms, counts)) {
        if (p == last_applied) {
          ++counts.repeated;
        } else {
          follower.apply(*p);
          last_applied = p;
        }
        wait_ms = 0;  // the line is free again: take the newest at once
      } else if (in.eof()) {
        break;
      } else {
        if (last_applied) follower.check();  // nothing new: look at the axis
        wait_ms = 100;
      }
      if (follower.servo_lost()) {
        throw CommandFailed(kFailure,
                            fmt::format("following stopped: the servo is off ({})",
                                        follower.last_flags().estop() ? "ESTOP = 1" : "SVRE = 0"));
      }
      if (follower.stopped_elsewhere()) {
        throw CommandFailed(
            kFailure,
            fmt::format("following stopped: {} = 1, set by another master (an HMI, lec serve): "
                        "lec follow sends nothing more and leaves it set",
                        follower.last_controls().test(lec::Coil::HOLD) ? "HOLD" : "RESET"));
      }
    }
    if (g_interrupted) throw client::Cancelled("interrupted");
  } catch (const client::Cancelled&) {
    if (last_applied) axis.stop();
    report(s, counts, follower.applied(), s.client().clock().now() - began, std::nullopt);
    throw client::Cancelled("interrupted: the axis was stopped (decelerating stop)");
  } catch (const UsageError&) {
    if (last_applied) axis.stop();  // bad input mid-stream: do not leave the axis going
    throw;
  }
  const Duration took = s.client().clock().now() - began;
  std::optional<client::MoveResult> last;
  with_move_report(s, [&] { last = follower.finish(s.deadline_in(a.timeout), s.wait_options()); });
  report(s, counts, follower.applied(), took, last);
  if (last && !last->succeeded()) throw CommandFailed(exit_code(*last), last->describe());
}

}  // namespace

void add_follow_command(CLI::App& app, Session& session) {
  auto a = std::make_shared<FollowArgs>();
  auto* f = app.add_subcommand(
      "follow", "Follow streamed target positions (mm per line, or JSON lines) from stdin or FILE");
  f->footer(
      "Each line is a position in mm (150.25) or {\"position_mm\": 150.25}. From a pipe or a "
      "terminal the newest setpoint is applied whenever the line is free and older ones are "
      "dropped (no backlog); a regular file is played in order. Each setpoint is two writes "
      "(D9104-D9105, D9100); the flags are read every --check-every setpoints. At the end of the "
      "input the last move is waited for and reported; Ctrl-C stops the axis (exit 130).");
  f->add_option("file", a->file, "Input file (default: - for stdin)");
  f->add_option("--speed", a->speed, "Speed, mm/s (1-65535)");
  f->add_option("--accel", a->accel, "Acceleration, mm/s² (1-65535)");
  f->add_option("--decel", a->decel, "Deceleration, mm/s² (1-65535)");
  f->add_option("--in-position", a->in_position, "In-position width for the last move, mm");
  f->add_option("--check-every", a->check_every,
                "Read the flags (alarm, servo) and the control coils (a HOLD or RESET another "
                "master set) after this many setpoints")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000u));
  add_deadline_option(f, a->timeout, "Deadline for the last move after the input ends");
  f->callback([&session, a] { run_follow(session, *a); });
}

}  // namespace lec6::cli
