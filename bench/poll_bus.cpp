// lec6_poll_bus: the multi-drop polling benchmark (bench/compare runs it).
//
//   lec6_poll_bus --port PTY --baud B --ids 1-16 [--seconds S] [--start-moves]
//                 [--twin-pid PID] [--no-silence-wait] [--json]
//
// Polls state (FC03 D9000x7) and flags (FC02 X40x16) of every ID, round
// robin, through lec6::client::Client on a SerialLink, and reports the full-bus
// refresh rate (complete rounds per second) against the line's limit:
//
//   per transaction  L = query wire + Ts + 4 ms + Td + reply wire   (digest §1)
//   per round, without inter-frame silence:  Σ_ids (L_state + L_flags)
//   per round, with it:                      Σ_ids (L_state + L_flags + 2·Ts)
//
// The second is the limit of a master that keeps the manual's rule (§8.2: Ts of
// silence before each query, so every listener closes the previous frame) —
// which our client does unless --no-silence-wait is given. Both are printed.
//
// --start-moves first puts every ID in serial mode, servo on, homes them all
// and starts a long direct move (ABS 390 mm at 1 mm/s: 6.5 min) on each, so
// the twin is polled with every carriage moving; the last round checks BUSY.
// --twin-pid measures that process's CPU time (/proc/PID/stat utime+stime and
// /proc/PID/schedstat) over the polling phase only.

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <sys/prctl.h>
#include <unistd.h>
#include <algorithm>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/transport/serial_link.hpp"

namespace {

using namespace lec6;

std::vector<uint8_t> parse_ids(const std::string& text) {
  std::set<int> ids;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto dash = item.find('-');
    const int lo = std::stoi(item.substr(0, dash));
    const int hi = dash == std::string::npos ? lo : std::stoi(item.substr(dash + 1));
    if (lo < 1 || hi > 255 || lo > hi) throw std::invalid_argument("--ids: bad range " + item);
    for (int i = lo; i <= hi; ++i) ids.insert(i);
  }
  return {ids.begin(), ids.end()};
}

// CPU time of a process: utime+stime in clock ticks, and the scheduler's
// nanosecond count (schedstat field 1), which is far finer.
struct CpuSample {
  double ticks_s = 0;
  double sched_s = 0;
  bool ok = false;
};

CpuSample cpu_of(int pid) {
  CpuSample s;
  std::ifstream stat(fmt::format("/proc/{}/stat", pid));
  std::string text;
  if (!std::getline(stat, text)) return s;
  // Fields after the command name (which may hold spaces) start after ") ".
  std::istringstream rest(text.substr(text.rfind(')') + 2));
  std::vector<std::string> f;
  for (std::string w; rest >> w;) f.push_back(w);
  if (f.size() < 13) return s;
  const double hz = static_cast<double>(::sysconf(_SC_CLK_TCK));
  s.ticks_s = (std::stod(f[11]) + std::stod(f[12])) / hz;  // fields 14 and 15
  std::ifstream sched(fmt::format("/proc/{}/schedstat", pid));
  double ns = 0;
  if (sched >> ns) s.sched_s = ns / 1e9;
  s.ok = true;
  return s;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

lec::StatusFlags flags_of(client::Client& c, uint8_t id) {
  c.set_id(id);
  return c.read_flags();
}

// Serial mode, servo on, home every ID (all at once), then a long direct move on each.
void start_moves(client::Client& c, const std::vector<uint8_t>& ids) {
  for (uint8_t id : ids) {
    c.set_id(id);
    c.write_coil(lec::Coil::SerialMode, true);
    c.write_coil(lec::Coil::SVON, true);
  }
  auto wait_all = [&](auto done, const char* what) {
    const TimePoint deadline = c.clock().now() + std::chrono::seconds(30);
    for (;;) {
      bool all = true;
      for (uint8_t id : ids) all = all && done(flags_of(c, id));
      if (all) return;
      if (c.clock().now() > deadline)
        throw std::runtime_error(fmt::format("timed out waiting for {}", what));
    }
  };
  wait_all([](const lec::StatusFlags& f) { return f.svre(); }, "SVRE");
  for (uint8_t id : ids) {
    c.set_id(id);
    c.write_coil(lec::Coil::SETUP, true);
  }
  wait_all([](const lec::StatusFlags& f) { return f.seton() && !f.busy(); }, "homing");
  lec::StepData d;
  d.movement_mode = lec::MovementMode::Absolute;
  d.speed_mm_s = 1;
  d.position_001mm = 39000;
  d.acceleration_mm_s2 = 1000;
  d.deceleration_mm_s2 = 1000;
  d.pushing_speed_mm_s = 20;
  d.moving_force_pct = 100;
  d.in_position_001mm = 50;
  for (uint8_t id : ids) {
    c.set_id(id);
    c.write_coil(lec::Coil::SETUP, false);
    c.write_direct(d);
    c.write_direct_start(client::Retry::Never);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Multi-drop polling benchmark: state + flags of every ID, round robin, against the line "
      "limit"};
  std::string port;
  uint32_t baud = 38400;
  std::string ids_text = "1-16";
  double seconds = 10;
  bool moves = false;
  int twin_pid = 0;
  bool no_silence_wait = false;
  bool json = false;
  long timer_slack_ns = 0;
  double idle_seconds = 0;
  app.add_option("--port", port, "The twin's pty (or a serial port)")->required();
  app.add_option("--baud", baud, "Line speed")->capture_default_str();
  app.add_option("--ids", ids_text, "IDs to poll, e.g. 1-16")->capture_default_str();
  app.add_option("--seconds", seconds, "How long to poll")->capture_default_str();
  app.add_flag("--start-moves", moves, "Home every ID and start a long direct move on each first");
  app.add_option("--twin-pid", twin_pid, "Measure this process's CPU over the polling phase");
  app.add_flag("--no-silence-wait", no_silence_wait,
               "Skip the client's Ts of silence before each query");
  app.add_flag("--json", json, "JSON output");
  app.add_option("--idle-seconds", idle_seconds,
                 "Before polling, measure the twin's CPU (--twin-pid) over this many seconds "
                 "without any query");
  app.add_option(
      "--timer-slack-ns", timer_slack_ns,
      "Set this thread's timer slack (prctl PR_SET_TIMERSLACK; the kernel default is 50000): how "
      "late the client's Ts silence wait may wake");
  CLI11_PARSE(app, argc, argv);

  try {
    if (timer_slack_ns > 0)
      ::prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(timer_slack_ns), 0UL, 0UL, 0UL);
    const auto ids = parse_ids(ids_text);
    transport::SerialOptions so;
    so.baud = baud;
    transport::SerialLink link(port, so);
    client::ClientOptions co;
    co.wait_for_silence = !no_silence_wait;
    client::Client c(link, co);
    if (moves) start_moves(c, ids);
    std::optional<double> idle_cpu_pct;
    if (twin_pid && idle_seconds > 0) {
      const CpuSample a = cpu_of(twin_pid);
      ::usleep(static_cast<useconds_t>(idle_seconds * 1e6));
      const CpuSample b = cpu_of(twin_pid);
      if (a.ok && b.ok) idle_cpu_pct = 100.0 * (b.sched_s - a.sched_s) / idle_seconds;
    }

    const auto& line = c.timing();
    const modbus::Request state_req =
        modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters};
    const modbus::Request flags_req = modbus::ReadBitsRequest{
        modbus::FunctionCode::ReadInputs, lec::kStatusInputs, lec::kStatusInputCount};
    auto limit_of = [&](const modbus::Request& r) {
      return to_ms(line.transaction_limit(modbus::encode_request({1, r})->size(),
                                          modbus::expected_response_length(r)));
    };
    const double l_state = limit_of(state_req);
    const double l_flags = limit_of(flags_req);
    const double ts = to_ms(line.silent_interval());
    const double n_ids = static_cast<double>(ids.size());
    const double round_limit_ms = n_ids * (l_state + l_flags);
    const double round_limit_ts_ms = n_ids * (l_state + l_flags + 2 * ts);

    // Warm-up round (opens nothing new, settles the twin's caches).
    for (uint8_t id : ids) {
      c.set_id(id);
      (void)c.read_state();
      (void)c.read_flags();
    }

    std::vector<double> lat_state, lat_flags;
    uint64_t rounds = 0;
    int moving = 0;
    const uint64_t retries_before = c.stats().retries;
    const CpuSample cpu0 = twin_pid ? cpu_of(twin_pid) : CpuSample{};
    const TimePoint start = c.clock().now();
    const TimePoint end = start + to_duration(FractionalSeconds(seconds));
    TimePoint now = start;
    while (now < end) {
      moving = 0;
      for (uint8_t id : ids) {
        c.set_id(id);
        (void)c.read_state();
        lat_state.push_back(to_ms(c.last_round_trip()));
        if (c.read_flags().busy()) ++moving;
        lat_flags.push_back(to_ms(c.last_round_trip()));
      }
      ++rounds;
      now = c.clock().now();
    }
    const double elapsed_s = to_seconds(now - start);
    const CpuSample cpu1 = twin_pid ? cpu_of(twin_pid) : CpuSample{};

    const double refresh_hz = static_cast<double>(rounds) / elapsed_s;
    const double limit_hz = 1000.0 / round_limit_ms;
    const double limit_ts_hz = 1000.0 / round_limit_ts_ms;
    nlohmann::json j{
        {"ids", ids.size()},
        {"baud", baud},
        {"silence_wait", !no_silence_wait},
        {"timer_slack_ns", static_cast<long>(::prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL))},
        {"rounds", rounds},
        {"seconds", elapsed_s},
        {"transactions", rounds * ids.size() * 2},
        {"retries", c.stats().retries - retries_before},
        {"refresh_hz", refresh_hz},
        {"limit_ms", {{"read_state", l_state}, {"read_flags", l_flags}, {"ts", ts}}},
        {"limit_hz", limit_hz},
        {"limit_with_ts_hz", limit_ts_hz},
        {"ratio_to_limit", refresh_hz / limit_hz},
        {"ratio_to_limit_with_ts", refresh_hz / limit_ts_hz},
        {"latency_ms",
         {{"read_state",
           {{"p50", percentile(lat_state, 0.5)}, {"p99", percentile(lat_state, 0.99)}}},
          {"read_flags",
           {{"p50", percentile(lat_flags, 0.5)}, {"p99", percentile(lat_flags, 0.99)}}}}},
        {"moving_in_last_round", moving},
    };
    if (idle_cpu_pct) j["twin_idle_cpu_pct"] = *idle_cpu_pct;
    if (twin_pid && cpu0.ok && cpu1.ok) {
      j["twin_cpu_pct"] = {{"stat", 100.0 * (cpu1.ticks_s - cpu0.ticks_s) / elapsed_s},
                           {"schedstat", 100.0 * (cpu1.sched_s - cpu0.sched_s) / elapsed_s}};
    }
    if (json) {
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print("{} IDs @ {} baud, state + flags round robin, {} rounds in {:.1f} s{}\n",
                 ids.size(), baud, rounds, elapsed_s, no_silence_wait ? " (no silence wait)" : "");
      fmt::print("  full-bus refresh {:.3f} Hz ({:.1f} ms per round)\n", refresh_hz,
                 1000.0 / refresh_hz);
      fmt::print(
          "  limit {:.3f} Hz without inter-frame Ts, {:.3f} Hz with it; ratio {:.3f} / {:.3f}\n",
          limit_hz, limit_ts_hz, refresh_hz / limit_hz, refresh_hz / limit_ts_hz);
      fmt::print(
          "  read-state p50 {:.3f} ms (limit {:.3f}), read-flags p50 {:.3f} ms (limit {:.3f})\n",
          percentile(lat_state, 0.5), l_state, percentile(lat_flags, 0.5), l_flags);
      fmt::print("  moving (BUSY) in the last round: {} of {}\n", moving, ids.size());
      if (j.contains("twin_cpu_pct")) {
        fmt::print("  twin CPU {:.2f} % of one core (schedstat), {:.2f} % (stat ticks)\n",
                   j["twin_cpu_pct"]["schedstat"].get<double>(),
                   j["twin_cpu_pct"]["stat"].get<double>());
      }
      if (idle_cpu_pct)
        fmt::print("  twin CPU with no queries (before polling): {:.3f} %\n", *idle_cpu_pct);
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "lec6_poll_bus: {}\n", e.what());
    return 1;
  }
}
