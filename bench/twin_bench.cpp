// The twin's request handling, sans-I/O: what `lec sim` spends per query on
// the CPU, apart from its system calls. A bus of 1, 16 or 64 controllers,
// idle or all moving (a long direct move on every ID), answering read-state
// queries in fast timing (frame complete on length) and real timing (frames
// delimited by Ts on the bytes' arrival times, as `lec sim --timing real`
// feeds them: one byte at a time on its virtual line).
//
// Also the whole in-process software stack: Client + SimLink + Bus on a
// VirtualClock (encode, framer, decode, twin; no operating system at all).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace {

using namespace lec6;

modbus::Bytes read_state_query(uint8_t id) {
  return *modbus::encode_request(
      {id, modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}});
}

// Serial mode, servo on, home, then a direct ABS move to 200 m at 1 mm/s
// (55 hours of motion) on every ID, through the client on the virtual clock.
void start_long_moves(sim::Bus& bus, VirtualClock& clock) {
  lec6::twin::SimLink link(bus, clock);
  client::Client c(link, {});
  const auto ids = bus.ids();
  for (uint8_t id : ids) {
    c.set_id(id);
    c.write_coil(lec::Coil::SerialMode, true);
    c.write_coil(lec::Coil::SVON, true);
  }
  clock.advance(std::chrono::milliseconds(200));  // SVRE
  for (uint8_t id : ids) {
    c.set_id(id);
    c.write_coil(lec::Coil::SETUP, true);
  }
  clock.advance(std::chrono::milliseconds(3000));  // homing from 10 mm at 20 mm/s
  lec::StepData d;
  d.movement_mode = lec::MovementMode::Absolute;
  d.speed_mm_s = 1;
  d.position_001mm = 20'000'000;
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
  clock.advance(std::chrono::milliseconds(100));
  for (uint8_t id : ids) {
    c.set_id(id);
    if (!c.read_flags().busy()) throw std::runtime_error("a controller is not moving");
  }
}

struct Twin {
  VirtualClock clock;
  std::unique_ptr<sim::Bus> bus;
  Twin(int controllers, sim::Timing timing, bool moving) {
    sim::LineConfig line;
    line.timing = timing;
    bus = std::make_unique<sim::Bus>(line);
    // A long stroke, so a benchmark that runs for hours of virtual time still
    // finds every carriage moving.
    sim::ActuatorConfig config;
    config.stroke_max_mm = 250000.0;
    for (int id = 1; id <= controllers; ++id)
      bus->add(static_cast<uint8_t>(id), config, clock.now());
    if (moving) start_long_moves(*bus, clock);
  }
};

// Fast timing: one query in, its reply out; time moves on 20 µs per query (or
// to the reply's end, if the bus schedules it later) so moving controllers do
// work on every advance.
void BM_Twin_Fast(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Twin twin(n, sim::Timing::Fast, state.range(1) != 0);
  std::vector<modbus::Bytes> queries;
  for (int id = 1; id <= n; ++id) queries.push_back(read_state_query(static_cast<uint8_t>(id)));
  TimePoint t = twin.clock.now();
  std::size_t next = 0;
  for (auto _ : state) {
    t += std::chrono::microseconds(20);
    twin.bus->receive(queries[next], t);
    auto replies = twin.bus->take_replies(t + std::chrono::seconds(1));
    if (replies.size() != 1) {
      state.SkipWithError("no reply");
      break;
    }
    t = std::max(t, replies.front().end);
    benchmark::DoNotOptimize(replies);
    if (++next == queries.size()) next = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetLabel(state.range(1) ? "moving" : "idle");
}

// Real timing as `lec sim` drives it: the query byte by byte on its line
// times, Ts to close the frame, the reply scheduled and taken.
void BM_Twin_Real(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Twin twin(n, sim::Timing::Real, state.range(1) != 0);
  const auto& line = twin.bus->line().line;
  std::vector<modbus::Bytes> queries;
  for (int id = 1; id <= n; ++id) queries.push_back(read_state_query(static_cast<uint8_t>(id)));
  TimePoint t = twin.clock.now();
  std::size_t next = 0;
  for (auto _ : state) {
    const auto& q = queries[next];
    for (std::size_t i = 0; i < q.size(); ++i) {
      t += line.char_time();
      twin.bus->receive(std::span(q).subspan(i, 1), t);
    }
    t += line.silent_interval();
    twin.bus->advance(t);
    t = *twin.bus->next_deadline();
    twin.bus->advance(t);
    auto replies = twin.bus->take_replies(t);
    if (replies.size() != 1) {
      state.SkipWithError("no reply");
      break;
    }
    t = replies.front().end;
    benchmark::DoNotOptimize(replies);
    if (++next == queries.size()) next = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetLabel(state.range(1) ? "moving" : "idle");
}

BENCHMARK(BM_Twin_Fast)->Args({1, 0})->Args({16, 0})->Args({64, 0})->Args({64, 1});
BENCHMARK(BM_Twin_Real)->Args({1, 0})->Args({16, 0})->Args({64, 0})->Args({64, 1});

// The whole stack in one process on a virtual clock: Client::read_state()
// against a fast-timing bus (encode, write, twin, framer, decode, typed state).
void BM_InProcess_ClientReadState(benchmark::State& state) {
  Twin twin(1, sim::Timing::Fast, false);
  lec6::twin::SimLink link(*twin.bus, twin.clock);
  client::ClientOptions o;
  o.wait_for_silence = false;
  client::Client c(link, o);
  for (auto _ : state) {
    auto s = c.read_state();
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_InProcess_ClientReadState);

}  // namespace
