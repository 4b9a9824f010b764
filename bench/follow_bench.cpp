// lec6_follow_bench: streaming setpoints (issue 12) against a twin in real
// timing, through the same client::Follower that `lec follow` uses.
//
//   lec sim --pty /tmp/twin --baud 115200 &
//   lec6_follow_bench --port /tmp/twin --baud 115200 --seconds 10 [--json]
//
// The source always has a fresh setpoint (a joystick faster than the line),
// so every setpoint the line allows is applied: setpoints/s is the rate of
// the line, not of the source. The figure is compared with the limit the
// issue sets: one write of the position (FC10 D9104–D9105: 13 B query, 8 B
// reply) plus one state read (FC03 D9000×7: 8 B, 19 B) per setpoint, each at
//   L = query wire + Ts + 4 ms + Td + reply wire        (digest §1).
// What we send per setpoint is printed too: the changed position word(s),
// the start (D9100; D9101 refuses writes, so it cannot share the FC10), and
// a flags read every --check-every setpoints.

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <sys/prctl.h>

#include <algorithm>
#include <vector>

#include "lec6/client/follower.hpp"
#include "lec6/transport/serial_link.hpp"

namespace {

using namespace lec6;

double limit_ms(const modbus::LineTiming& t, std::size_t query, std::size_t reply) {
  return to_ms(t.transaction_limit(query, reply));
}

// Where each transaction's time goes beyond the timing rule, from the
// client's trace (sent: before the write; received: the reply complete):
//   over L  = (reply complete − write begun) − L(query, reply): the pty
//             hand-overs both ways, the twin's lateness, our wake-up;
//   over Ts = (next write begun − reply complete) − Ts: our wait for the
//             silent interval and the follower's own work.
class Breakdown {
 public:
  void on(const client::TraceEvent& e) {
    if (!measuring_) return;

    if (e.outgoing) {
      if (have_end_) gaps_.push_back(to_ms(e.at - end_));
      start_ = e.at;
      query_ = e.bytes.size();
      have_end_ = false;
    } else {
      end_ = e.at;
      have_end_ = true;
      trips_.push_back({to_ms(e.at - start_), query_, e.bytes.size()});
    }
  }
  void start() { measuring_ = true; }
  void stop() { measuring_ = false; }

  void print(const modbus::LineTiming& t) {
    std::vector<double> over_l, over_ts;
    for (const auto& r : trips_) over_l.push_back(r.ms - limit_ms(t, r.query, r.reply));
    for (double g : gaps_) over_ts.push_back(g - to_ms(t.silent_interval()));
    fmt::print("per transaction, beyond the rule (ms): over L {}; over Ts {}\n", summary(over_l),
               summary(over_ts));
  }

 private:
  struct Trip {
    double ms;
    std::size_t query, reply;
  };
  static std::string summary(std::vector<double> v) {
    if (v.empty()) return "(none)";
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (double x : v) sum += x;
    auto at = [&](double q) { return v[static_cast<std::size_t>(q * (v.size() - 1))]; };
    return fmt::format("mean {:.3f} p50 {:.3f} p90 {:.3f} max {:.3f}",
                       sum / static_cast<double>(v.size()), at(0.5), at(0.9), v.back());
  }

  bool measuring_ = false;
  bool have_end_ = false;
  TimePoint start_{}, end_{};
  std::size_t query_ = 0;
  std::vector<Trip> trips_;
  std::vector<double> gaps_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lec6_follow_bench: setpoints/s of `lec follow`'s Follower against the line limit"};
  std::string port;
  uint32_t baud = 38400;
  double seconds = 10;
  unsigned check_every = 8;
  bool json = false;
  bool breakdown = false;
  app.add_option("--port", port, "The twin's pty")->required();
  app.add_option("--baud", baud, "The twin's baud rate")->capture_default_str();
  app.add_option("--seconds", seconds, "How long to stream")->capture_default_str();
  app.add_option("--check-every", check_every, "Flags read after this many setpoints")
      ->capture_default_str();
  app.add_flag("--json", json, "One JSON object");
  app.add_flag("--breakdown", breakdown,
               "Also print where each transaction's time goes beyond L and Ts");
  CLI11_PARSE(app, argc, argv);
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);  // wake at the instant asked, as the twin does

  try {
    transport::SerialOptions so;
    so.baud = baud;
    transport::SerialLink link(port, so);
    Breakdown parts;
    client::ClientOptions co;
    if (breakdown) co.trace = [&parts](const client::TraceEvent& e) { parts.on(e); };
    client::Client c(link, co);
    client::Actuator axis(c);
    axis.set_serial_mode(true);
    axis.servo_on(axis.deadline_in(std::chrono::seconds(5)));
    if (!c.read_flags().seton()) axis.home(axis.deadline_in(std::chrono::seconds(60)));

    client::FollowOptions o;
    o.move.speed_mm_s = 500;
    o.move.acceleration_mm_s2 = 5000;
    o.move.deceleration_mm_s2 = 5000;
    o.check_every = check_every;
    client::Follower follower(axis, o);
    follower.apply(10000);  // the first setpoint writes the whole record
    const uint64_t tx_before = c.stats().transactions;
    const TimePoint start = c.clock().now();
    const TimePoint end = start + to_duration(FractionalSeconds(seconds));
    uint64_t n = 0;
    parts.start();
    while (c.clock().now() < end) {
      // A wave between 100 and 200 mm: every setpoint differs from the last.
      follower.apply(10000 + static_cast<int32_t>((n * 37) % 10000));
      ++n;
    }
    const double took = to_seconds(c.clock().now() - start);
    parts.stop();
    const uint64_t tx = c.stats().transactions - tx_before;
    const auto& t = c.timing();
    const double lim_ms = limit_ms(t, 13, 8) + limit_ms(t, 8, 19);
    const double rate = static_cast<double>(n) / took;
    const double limit = 1000.0 / lim_ms;
    const double ts = to_ms(t.silent_interval());
    if (json) {
      nlohmann::json j{{"baud", baud},
                       {"seconds", took},
                       {"setpoints", n},
                       {"setpoints_per_s", rate},
                       {"transactions_per_setpoint", static_cast<double>(tx) / n},
                       {"limit_ms", lim_ms},
                       {"limit_setpoints_per_s", limit},
                       {"ratio", rate / limit},
                       {"retries", c.stats().retries},
                       {"ts_ms", ts}};
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print(
          "{} setpoints in {:.2f} s at {} baud: {:.1f} setpoints/s, {:.3f} transactions "
          "each ({} retries)\n",
          n, took, baud, rate, static_cast<double>(tx) / n, c.stats().retries);
      fmt::print(
          "limit (one position write 13/8 B + one state read 8/19 B): {:.3f} ms = {:.1f} "
          "setpoints/s; ratio {:.3f}\n",
          lim_ms, limit, rate / limit);
      if (breakdown) parts.print(t);
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "lec6_follow_bench: {}\n", e.what());
    return 1;
  }
}
