// The line simulation's plant (world.hpp): what a seed draws (controllers
// clean, dead, noisy or flapping; the line's speed; the telemetry), and the
// actors that use the line: PLCs writing output images, SCADA floods, an
// HMI that opens a connection per read, operators' stops and jogs.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <span>

#include "lec6/lec/memory_map.hpp"
#include "serve/sim/world.hpp"

namespace lec6::serve::sim_testing::detail {

void World::draw_plant() {
  const int n = pick(1, 8);
  timing_.baud = chance(0.5) ? 38400 : 115200;
  SchedulerConfig config;
  config.timing = timing_;
  config.offline_after = 3;
  config.probe_interval = std::chrono::milliseconds(pick(200, 2000));
  std::string words = fmt::format("{} controllers at {} baud:", n, timing_.baud);
  for (int i = 1; i <= n; ++i) {
    Device d;
    d.id = static_cast<uint8_t>(i);
    const double r = std::uniform_real_distribution<double>(0, 1)(rng_);
    d.kind = r < 0.55   ? Kind::Clean
             : r < 0.7  ? Kind::Dead
             : r < 0.85 ? Kind::Noisy
                        : Kind::Flapping;
    if (i == 1) d.kind = Kind::Clean;  // the operator's axis answers
    if (d.kind == Kind::Noisy) d.fail = std::uniform_real_distribution<double>(0.05, 0.5)(rng_);
    if (d.kind == Kind::Flapping) {
      d.dead_from = clock_ + std::chrono::milliseconds(pick(0, 2000));
      d.dead_until = d.dead_from + std::chrono::milliseconds(pick(300, 3000));
    }
    if (d.kind != Kind::Dead) {
      d.twin = std::make_unique<sim::Controller>(sim::ActuatorConfig{}, clock_);
      const auto on = [&](Coil c) {
        d.twin->handle(modbus::WriteCoilRequest{lec::address(c), modbus::kCoilOn}, clock_);
      };
      on(Coil::SerialMode);
      on(Coil::SVON);
    }
    config.axes.push_back(
        {d.id, chance(0.7) ? std::chrono::milliseconds(pick(50, 200)) : Duration{}});
    words += fmt::format(" {}={}", i,
                         d.kind == Kind::Clean   ? "clean"
                         : d.kind == Kind::Dead  ? "dead"
                         : d.kind == Kind::Noisy ? fmt::format("noisy({:.2f})", d.fail)
                                                 : "flapping");
    devices_[d.id] = std::move(d);
  }
  clock_ += 1s;  // the servos turn on
  start_ = clock_;
  s_ = std::make_unique<Scheduler>(config, clock_);
  policy_.units.clear();
  for (const auto& [id, d] : devices_) policy_.units.insert(id);
  const auto some_ids = [&] {
    std::vector<uint8_t> ids;
    for (const auto& [id, d] : devices_)
      if (chance(0.5)) ids.push_back(id);
    if (ids.empty()) ids.push_back(static_cast<uint8_t>(pick(1, n)));
    return ids;
  };
  for (int i = pick(0, 2); i > 0; --i) {
    Actor a{Actor::Type::Plc,
            std::chrono::milliseconds(pick(10, 100)),
            clock_,
            some_ids(),
            pick(0, 2),
            chance(0.3),
            0};
    for (uint8_t id : a.ids) devices_[id].driven_by_plc = true;
    words += fmt::format("; PLC every {} ms (FC{}) to {} IDs", ms(a.period),
                         a.encoding == 0   ? "05"
                         : a.encoding == 1 ? "0F"
                                           : "10 D90C1",
                         a.ids.size());
    actors_.push_back(a);
  }
  // Some listeners answer reads from the cache (ListenerConfig's
  // cache_max_age): masters that miss together are answered from it when
  // their turn comes, after the first one's read.
  const auto cache_age = [&] {
    return chance(0.5) ? Duration(std::chrono::milliseconds(pick(20, 300))) : Duration{};
  };
  for (int i = pick(0, 3); i > 0; --i) {
    Actor a{Actor::Type::Scada,
            20ms,
            clock_,
            some_ids(),
            0,
            chance(0.3),
            static_cast<std::size_t>(pick(3, 20))};
    a.cache_age = cache_age();
    words += fmt::format("; SCADA flood (cache {} ms)", ms(a.cache_age));
    actors_.push_back(std::move(a));
  }
  if (chance(0.4)) {  // a new connection per read: CommandTurns::forget_idle's client
    Actor a{Actor::Type::Hmi, std::chrono::milliseconds(pick(5, 20)), clock_, some_ids()};
    a.hangs_up = chance(0.8);
    a.depth = static_cast<std::size_t>(pick(2, 6));
    a.cache_age = cache_age();
    words += fmt::format("; HMI, a connection per read, {} at a time (cache {} ms)", a.depth,
                         ms(a.cache_age));
    actors_.push_back(std::move(a));
  }
  actors_.push_back({Actor::Type::Operator,
                     std::chrono::milliseconds(pick(100, 700)),
                     clock_ + 200ms,
                     {},
                     0,
                     chance(0.3),
                     0});
  actors_.push_back({Actor::Type::Jogger, 400ms, clock_, {}, 0, false, 0});
  // Each its own connection; the jogger's operations and the HMI's
  // connections each a source of its own (next_source_).
  for (std::size_t i = 0; i < actors_.size(); ++i) actors_[i].source = i + 1;
  next_source_ = actors_.size() + 1;
  if (chance(0.2)) {
    shutdown_at_ = clock_ + std::chrono::milliseconds(pick(300, 2700));
    words += "; shutdown";
  }
  run_.plant = words;
  note(0, 0, [&] { return words; });
}

void World::act() {
  for (Actor& a : actors_) {
    while (a.next <= clock_) {
      a.next += a.period;
      switch (a.type) {
        case Actor::Type::Plc:
          for (uint8_t id : a.ids)
            if (a.outstanding < kMaxQueued) plc_image(a, id);
          break;
        case Actor::Type::Scada:
          // Keeps `depth` reads queued (refused ones come back at once; one
          // the cache answered at once waits for the next poll).
          for (std::size_t n = 0;
               n < a.depth && s_->queue_depth()[index(Priority::Command)] < a.depth; ++n) {
            const std::size_t cached = cache_answers_;
            submit_tcp(any_of(a.ids), block_request(Block::State),
                       {.source = a.source,
                        .hangs_up = a.hangs_up,
                        .connection = &a,
                        .cache_age = a.cache_age});
            if (cache_answers_ > cached) break;
          }
          break;
        case Actor::Type::Hmi:
          // A read answered at once (the cache, a controller backed off) frees its slot at once.
          for (std::size_t n = 0; n < a.depth && a.outstanding < a.depth; ++n) {
            const Block b = chance(0.5) ? Block::Flags : Block::State;
            submit_tcp(any_of(a.ids), block_request(b),
                       {.source = next_source_++,
                        .hangs_up = a.hangs_up,
                        .bounded = &a,
                        .cache_age = a.cache_age});
          }
          break;
        case Actor::Type::Operator:
          operator_stop(a);
          a.period = std::chrono::milliseconds(pick(100, 700));
          break;
        case Actor::Type::Jogger:
          jog();
          break;
      }
    }
  }
}

uint8_t World::any_of(const std::vector<uint8_t>& ids) {
  return ids[static_cast<std::size_t>(pick(0, static_cast<int>(ids.size()) - 1))];
}

void World::plc_image(Actor& a, uint8_t id) {
  // An output image: running (servo on, maybe DRIVE), or a stop in it.
  const int what = pick(0, 9);
  bool hold = what == 7, svon = what != 8, reset = what == 9;
  std::array<bool, 16> y{};  // Y10-Y1F
  y[0x18 - 0x10] = hold;
  y[0x19 - 0x10] = svon;
  y[0x1B - 0x10] = reset;
  modbus::Request r;
  if (a.encoding == 0) {
    const Coil c = hold ? Coil::HOLD : reset ? Coil::RESET : Coil::SVON;
    const bool on = c == Coil::SVON ? svon : true;
    r = modbus::WriteCoilRequest{lec::address(c), on ? modbus::kCoilOn : modbus::kCoilOff};
  } else if (a.encoding == 1) {
    r = modbus::WriteCoilsRequest::of(0x18, std::span<const bool>(&y[8], 7));
  } else {
    uint16_t word = 0;
    for (int b = 0; b < 16; ++b) word |= static_cast<uint16_t>(y[b]) << b;
    const uint16_t words[] = {word};
    r = modbus::WriteRegistersRequest::of(lec::kControlWordY10, words);
  }
  submit_tcp(id, std::move(r), {.source = a.source, .hangs_up = a.hangs_up, .bounded = &a});
}

void World::operator_stop(const Actor& a) {
  const uint8_t id = static_cast<uint8_t>(pick(1, static_cast<int>(devices_.size())));
  const Via via{.source = a.source, .hangs_up = a.hangs_up, .by_operator = true};
  if (chance(0.5)) {
    submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::RESET), modbus::kCoilOn}, via);
    submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::RESET), modbus::kCoilOff}, via);
  } else {
    submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::HOLD), modbus::kCoilOn}, via);
  }
}

// An operator's jog on a controller no PLC drives: HOLD off, JOG+ on for a
// while, off. Each an operation of its own (HTTP): a source of its own.
void World::jog() {
  for (auto& [id, d] : devices_) {
    if (d.kind != Kind::Clean || d.driven_by_plc || !chance(0.3)) continue;
    const bool on = chance(0.6);
    const Via via{.source = next_source_++, .jog = true};
    if (on)
      submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::HOLD), modbus::kCoilOff}, via);
    submit_tcp(id,
               modbus::WriteCoilRequest{lec::address(Coil::JOG_PLUS),
                                        on ? modbus::kCoilOn : modbus::kCoilOff},
               via);
  }
}

}  // namespace lec6::serve::sim_testing::detail
