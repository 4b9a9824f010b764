// lec doctor's probes: see doctor_probes.hpp. What they find is judged by
// client/doctor (sans-I/O); the line they ask is the caller's.

#include "cli/doctor_probes.hpp"

#include <algorithm>

#include "cli/doctor_line.hpp"
#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/alarms.hpp"

namespace lec6::cli::doctor_probes {

namespace dx = client::doctor;
using doctor_line::kStateReplyBytes;
using doctor_line::LineProbe;
using doctor_line::state_query;
using std::chrono::milliseconds;

bool Fix::may_set_serial(uint8_t id) const {
  return on && std::find(serial_ids.begin(), serial_ids.end(), id) != serial_ids.end();
}

namespace {

// The port at `baud`, echo not discarded (the probes want to see it).
LineProbe at_baud(const ProbeLine& line, const ProbeSettings& s, uint32_t baud) {
  modbus::LineTiming t;
  t.baud = baud;
  t.silent_interval_k = s.silent_interval_k;
  t.delay_td = s.delay_td;
  return LineProbe(line.open(baud, false), t, line.wait);
}

void note_foreign(dx::Observations& obs, const modbus::Bytes& heard) {
  obs.listened += kListen;
  obs.foreign_bytes += heard.size();
  for (uint8_t id : dx::foreign_queries(heard)) obs.foreign_query_ids.push_back(id);
}

// 1. Baud and IDs: the first rate where something answers.
void search(const ProbeLine& line, const ProbeSettings& g, const std::vector<uint8_t>& ids,
            dx::Observations& obs) {
  std::vector<uint32_t> order{g.baud};
  for (uint32_t b : modbus::kBaudRates)
    if (b != g.baud) order.push_back(b);
  const TimePoint until = line.clock->now() + kSearchBudget;
  // First pass: short windows. Nothing anywhere: a second pass with the full
  // reply margin (a slow converter, a busy host), within the same budget.
  for (int pass = 0; pass < 2; ++pass) {
    const Duration window_margin = pass == 0 ? kScanMargin : std::max(kScanMargin, g.reply_margin);
    if (pass == 1 && window_margin == kScanMargin) break;
    for (uint32_t baud : order) {
      if (line.interrupted()) break;
      if (line.clock->now() >= until) {
        obs.budget_ran_out = true;
        break;
      }
      LineProbe p = at_baud(line, g, baud);
      // 6. Another master: listen before sending anything.
      if (obs.bauds.empty()) note_foreign(obs, p.listen(kListen));
      dx::BaudProbe bp;
      bp.baud = baud;
      auto scan = [&](Duration margin) {
        bp = {};
        bp.baud = baud;
        // An echo is the adapter's when most queries come back (a 2-wire
        // adapter echoes every one), not when one does: another master's
        // query to the same ID, in our window, is our query byte for byte
        // (a reviewer's finding: "echo" on a line with another master, and
        // the controllers then read with echo discard failed).
        int asked = 0, echoes = 0;
        for (uint8_t id : ids) {
          if (line.interrupted() || line.clock->now() >= until) break;
          const auto h = p.exchange(state_query(id), kStateReplyBytes, margin);
          ++asked;
          // Another master heard asking this ID: its query is no echo of ours.
          const bool theirs =
              std::ranges::find(obs.foreign_query_ids, id) != obs.foreign_query_ids.end();
          if (h.result.echo && !theirs) ++echoes;
          bp.echo = echoes * 2 > asked;
          bp.stray_bytes += h.result.noise_bytes;
          switch (h.result.kind) {
            case dx::ReplyKind::Good:
            case dx::ReplyKind::Exception:
              bp.answering.push_back(id);
              break;
            case dx::ReplyKind::Crc:
            case dx::ReplyKind::Framing:
              bp.garbled.push_back(id);
              break;
            default:
              break;
          }
        }
      };
      scan(window_margin);
      // Noise on the line at the rate the user gave (or lec's default), and
      // no answer: a garbled query gets no reply at all, so one scan can miss
      // a controller that is there. kNoisyRescans more at that rate only (a
      // noisy line is noisy at every rate: asking again everywhere would cost
      // the search's budget). At half the exchanges lost, one scan misses
      // the controller every other time, five scans about once in 32 (and
      // the rescan with the full reply margin below is one more).
      for (int again = 0; again < kNoisyRescans && baud == order.front() && bp.answering.empty() &&
                          (bp.stray_bytes > 0 || !bp.garbled.empty());
           ++again) {
        const dx::BaudProbe before = bp;
        scan(window_margin);
        bp.stray_bytes += before.stray_bytes;
        for (uint8_t id : before.garbled)
          if (std::find(bp.garbled.begin(), bp.garbled.end(), id) == bp.garbled.end())
            bp.garbled.push_back(id);
        std::sort(bp.garbled.begin(), bp.garbled.end());
        std::erase_if(bp.garbled, [&](uint8_t id) {
          return std::find(bp.answering.begin(), bp.answering.end(), id) != bp.answering.end();
        });
        bp.echo = bp.echo || before.echo;
      }
      // Bytes but no answer: perhaps replies later than the short window (a
      // slow converter, a busy host): once more with the full reply margin.
      Duration asked_with = window_margin;
      if (pass == 0 && bp.answering.empty() && (bp.stray_bytes > 0 || !bp.garbled.empty()) &&
          g.reply_margin > kScanMargin) {
        scan(g.reply_margin);
        asked_with = g.reply_margin;
      }
      // Bytes heard while some IDs answered and others did not: a reply later
      // than the short window lands in the next exchange as stray bytes (a
      // controller with a longer Td, or a busy host: a clean make test run
      // missed a duplicate ID so in two runs). The silent IDs once more with
      // the full reply margin. (The last ID's late reply has no next exchange
      // to land in: not seen so.)
      if (!bp.answering.empty() && bp.stray_bytes > 0 && g.reply_margin > asked_with) {
        for (uint8_t id : ids) {
          if (line.interrupted() || line.clock->now() >= until) break;
          if (std::ranges::binary_search(bp.answering, id) ||
              std::ranges::find(bp.garbled, id) != bp.garbled.end())
            continue;
          const auto k = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin).result.kind;
          if (dx::answered(k)) {
            bp.answering.insert(std::ranges::upper_bound(bp.answering, id), id);
          } else if (k == dx::ReplyKind::Crc || k == dx::ReplyKind::Framing) {
            bp.garbled.push_back(id);
          }
        }
      }
      if (!bp.answering.empty() || !bp.garbled.empty()) {
        // A garbled reply carried its ID at this rate: that controller is
        // there (a collision or noise); ask it again, so the later checks
        // include it. Also when no other answered: on a noisy line with one
        // controller its one scan query may be garbled, and the doctor said
        // "nothing answers at any baud" (seen once in a test run).
        std::vector<uint8_t> still;
        for (uint8_t id : bp.garbled) {  // Crc, Framing: a reply that carried the ID
          bool ok = false;
          bool again = false;  // garbled again: not noise that began with its ID
          for (int i = 0; i < 3 && !ok && !line.interrupted() && line.clock->now() < until; ++i) {
            const auto k =
                p.exchange(state_query(id), kStateReplyBytes, std::max(kScanMargin, g.reply_margin))
                    .result.kind;
            ok = dx::answered(k);
            again = again || k == dx::ReplyKind::Crc || k == dx::ReplyKind::Framing;
          }
          if (ok) {
            bp.answering.insert(std::upper_bound(bp.answering.begin(), bp.answering.end(), id), id);
          } else {
            still.push_back(id);
            if (again) bp.garbled_again.push_back(id);
          }
        }
        bp.garbled = still;
      }
      obs.echo_seen = obs.echo_seen || bp.echo;
      if (pass == 1) {  // the second look replaces the first at this rate
        std::erase_if(obs.bauds, [&](const dx::BaudProbe& b) { return b.baud == baud; });
      }
      obs.bauds.push_back(bp);
      if (!bp.answering.empty()) {
        obs.found_baud = baud;
        if (obs.bauds.size() > 1) note_foreign(obs, p.listen(kListen));  // at the right rate too
        return;
      }
    }
  }
}

// 5, 7, 4. A short burst of reads, round robin over the IDs that answered.
void burst(const ProbeLine& line, const ProbeSettings& g, const std::vector<uint8_t>& ids,
           dx::Observations& obs) {
  LineProbe p = at_baud(line, g, *obs.found_baud);
  auto& b = obs.burst;
  b.query_bytes = state_query(1).size();
  b.reply_bytes = kStateReplyBytes;
  const TimePoint until = line.clock->now() + kBurstBudget;
  // No reply can be complete sooner: one that is was late for the query before.
  const Duration fastest = p.timing().wire_time(b.query_bytes) +
                           p.timing().wire_time(b.reply_bytes) + modbus::LineTiming::kProcessing;
  int too_fast = 0;
  for (int i = 0; i < kBurstExchanges && line.clock->now() < until && !line.interrupted(); ++i) {
    const uint8_t id = ids[static_cast<std::size_t>(i) % ids.size()];
    // 0-16 ms more between exchanges, spread evenly: a USB adapter's latency
    // timer ticks on its own clock; paced at one rate, every reply would
    // meet it at the same phase and the lumps would look like a longer Td.
    line.wait(milliseconds((i * 7) % 17));
    auto h = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin);
    ++b.exchanges;
    ++b.per_id_exchanges[id];
    const auto whole = [](dx::ReplyKind k) { return dx::answered(k); };
    const bool answered = whole(h.result.kind);
    if (h.result.kind == dx::ReplyKind::None || h.result.kind == dx::ReplyKind::Garbage ||
        h.result.kind == dx::ReplyKind::Framing) {
      // No whole reply in its window (nothing, or only its first bytes: a
      // USB adapter hands replies over in lumps): listen one more margin. A
      // whole reply then is late, not lost or garbled (a slow controller,
      // adapter or host: the reply window is what to change, not the
      // cabling); either way it must not answer the next query.
      const modbus::Bytes more = p.listen(g.reply_margin);
      h.bytes.insert(h.bytes.end(), more.begin(), more.end());
      const auto late = dx::classify_exchange(state_query(id), h.bytes);
      if (whole(late.kind)) {
        ++b.late;
        b.noise_bytes += late.noise_bytes;
        continue;
      }
      // Late and garbled (a collision that came after the window): garbled,
      // as it would have been in time, not a timeout.
      if (late.kind == dx::ReplyKind::Crc || late.kind == dx::ReplyKind::Framing) h.result = late;
    } else if (!answered || h.round_trip < fastest) {
      // A late reply still on its way must not answer the next query.
      line.wait(g.reply_margin);
    }
    std::size_t noise = h.result.noise_bytes;
    if (answered && h.round_trip < fastest) {
      // The previous query's late reply, then ours: our reply after it is
      // no noise (a fast twin on a loaded host, make test: 19 "noise" bytes
      // a time, and the cabling blamed).
      const auto rest = std::span<const uint8_t>(h.bytes).subspan(
          std::min(h.bytes.size(), h.result.reply_offset + h.result.reply_bytes));
      const auto ours = dx::classify_exchange(state_query(id), rest);
      if (whole(ours.kind) && ours.reply_offset == 0) noise -= std::min(noise, ours.reply_bytes);
    }
    b.noise_bytes += noise;
    switch (h.result.kind) {
      case dx::ReplyKind::Good:
      case dx::ReplyKind::Exception:
        if (h.round_trip < fastest) {
          // The previous query's late reply (ours came after the window), or
          // a line that no wire paces: told apart below, over the burst.
          ++too_fast;
          break;
        }
        ++b.good;
        b.round_trips.push_back(h.round_trip);
        break;
      case dx::ReplyKind::Crc:
        ++b.crc;
        ++b.per_id_garbled[id];
        break;
      case dx::ReplyKind::Framing:
        ++b.framing;
        ++b.per_id_garbled[id];
        break;
      default:
        ++b.timeouts;
        break;
    }
  }
  dx::account_too_fast(b, too_fast);
}

// 4. Silent INT: does a query in two parts, a gap longer than lec's Ts
// apart, still get an answer? Then the controller's Ts is longer: bracket it.
void probe_silent_interval(const ProbeLine& line, const ProbeSettings& g, uint8_t id,
                           dx::Observations& obs) {
  LineProbe p = at_baud(line, g, *obs.found_baud);
  const Duration ts = p.timing().silent_interval();
  // Two of three answered: a late wake-up (ours, or a twin's on a busy host)
  // can close or stretch a gap once, rarely twice.
  auto one_frame = [&](Duration gap) {
    int answered = 0;
    for (int i = 0; i < 3 && answered < 2 && answered + (3 - i) >= 2; ++i) {
      const auto k = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin, gap).result.kind;
      answered += dx::answered(k);
    }
    return answered >= 2;
  };
  // Far enough above Ts that timer and adapter jitter cannot close the gap.
  Duration lo = std::max<Duration>(ts * 3, milliseconds(2));
  obs.ts_gap_tried = lo;
  if (!one_frame(lo)) return;
  // Bracket: double until a gap ends the frame (Ts is at most 100 x 3.5 chars).
  const Duration ts_max = ts * 100 / static_cast<int64_t>(g.silent_interval_k);
  Duration hi = lo * 2;
  while (hi <= ts_max && one_frame(hi)) {
    lo = hi;
    hi = hi * 2;
  }
  for (int i = 0; i < 3; ++i) {
    const Duration mid = (lo + hi) / 2;
    if (one_frame(mid)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  obs.ts_above = lo;
}

// 2. Echo: does echo discard make transactions work?
bool echo_fix_works(const ProbeLine& line, uint8_t id, uint32_t baud) {
  try {
    auto port = line.open(baud, true);
    client::Client c(port->master(), {.id = id, .retries = 2});
    c.read_state();
    return true;
  } catch (const client::TransportError&) {
    return false;
  } catch (const client::LinkError& e) {
    if (e.kind() == client::LinkErrorKind::PortUnavailable) throw;
    return false;
  }
}

// 8. Each controller's state, read only (--fix: serial mode on, alarms reset).
dx::ControllerState read_controller(client::Client& c, client::Actuator& axis, uint8_t id,
                                    const Fix& fix) {
  // ALARM is never decided from X4F alone (issue 33): checked against the code below.
  dx::ControllerState st;
  st.id = id;
  c.set_id(id);
  try {
    auto controls = c.read_controls();
    if (fix.may_set_serial(id) && !controls.serial_mode) {
      axis.set_serial_mode(true);
      controls = c.read_controls();
      if (controls.serial_mode) st.fixed.push_back("serial mode on (Y30)");
    }
    auto flags = c.read_flags();
    auto alarms = axis.active_alarms(flags);
    std::vector<uint8_t> left;  // resettable codes a RESET left (lec::alarm_after_reset)
    if (fix.on && !alarms.empty() &&
        std::all_of(alarms.begin(), alarms.end(), lec::alarm_resettable) && controls.serial_mode) {
      left = axis.reset_alarms();
      for (uint8_t a : alarms)
        if (std::find(left.begin(), left.end(), a) == left.end())
          st.fixed.push_back(fmt::format("alarm {} cleared (RESET)", a));
      flags = c.read_flags();
      alarms = axis.active_alarms(flags);
    }
    st.serial_mode = controls.serial_mode;
    st.servo_on = controls.test(lec::Coil::SVON);
    st.svre = flags.svre();
    st.homed = flags.seton();
    st.estop = flags.estop();
    const auto judged =
        lec::judge_alarm(flags, c.read_alarms().groups[0], c.options().alarm_polarity);
    st.alarms = judged.codes;
    st.alarm_check = judged.disagreement;
    if (st.alarm_check.empty() && !left.empty() && judged.active)
      st.alarm_check = lec::alarm_after_reset(left, c.options().alarm_polarity);
    try {
      st.name = c.read_name().text;
    } catch (const client::TransportError&) {
    } catch (const client::ControllerException&) {
    }
  } catch (const client::TransportError& e) {
    st.read_error = e.what();
  } catch (const client::ControllerException& e) {
    st.read_error = e.what();
  }
  return st;
}

}  // namespace

void read_controllers(twin::OpenPort& port, const ProbeSettings& s, const std::vector<uint8_t>& ids,
                      const Fix& fix, const std::function<bool()>& interrupted,
                      dx::Observations& obs) {
  client::Client c(port.master(),
                   {.id = ids.front(), .retries = 2, .alarm_polarity = s.alarm_polarity});
  client::Actuator axis(c);
  for (uint8_t id : ids) {
    if (interrupted()) break;
    obs.controllers.push_back(read_controller(c, axis, id, fix));
  }
}

dx::Observations asked(std::string port, std::string id_range, bool echo_option, bool fix,
                       const ProbeSettings& s) {
  dx::Observations obs;
  obs.port = std::move(port);
  obs.id_range = std::move(id_range);
  obs.echo_option = echo_option;
  obs.fix = fix;
  obs.assumed.baud = s.baud;
  obs.assumed.silent_interval_k = s.silent_interval_k;
  obs.assumed.delay_td = s.delay_td;
  return obs;
}

void probe_line(const ProbeLine& line, const ProbeSettings& s, const std::vector<uint8_t>& ids,
                const Fix& fix, bool echo_option, dx::Observations& obs,
                const std::function<void()>& before_controllers) {
  search(line, s, ids, obs);
  if (!obs.found_baud) return;
  obs.assumed.baud = *obs.found_baud;
  const auto& found = obs.bauds.back().answering;
  if (obs.echo_seen) obs.echo_fix_works = echo_fix_works(line, found.front(), *obs.found_baud);
  // The burst asks the IDs whose replies were garbled every time asked
  // too: they are there, and two controllers on one ID whose every reply
  // collides are the duplicate the burst must see. (Not an ID garbled
  // once and silent since: noise that began with its ID, a reviewer
  // showed, would make a phantom of it.)
  std::vector<uint8_t> asked = found;
  for (uint8_t id : obs.bauds.back().garbled_again) asked.push_back(id);
  std::ranges::sort(asked);
  burst(line, s, asked, obs);
  // Not with another master on the line: its replies would answer for ours.
  if (obs.foreign_query_ids.empty()) probe_silent_interval(line, s, found.front(), obs);
  if (before_controllers) before_controllers();
  auto port = line.open(*obs.found_baud, obs.echo_seen || echo_option);
  read_controllers(*port, s, obs.bauds.back().answering, fix, line.interrupted, obs);
}

}  // namespace lec6::cli::doctor_probes
