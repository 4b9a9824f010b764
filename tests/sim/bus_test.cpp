// The twin on the wire: raw frames in, raw replies out, on a virtual clock.
// Golden frames come from tests/data/manual-frames.tsv (the manual's examples).
// Over 450 lines: one case per manual rule on the wire (each FC, exceptions,
// broadcast, timing, faults), kept in one suite so the rules read side by side.

#include "lec6/sim/bus.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lec6/error.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/crc.hpp"

#include "test_time.hpp"

namespace lec6::sim {
namespace {

using modbus::Bytes;
using modbus::ExceptionCode;

using testing::ms;

Bytes hex(std::string_view text) {
  return modbus::from_hex(text).value();
}

// The manual's example frames, by section and kind, in file order.
struct ManualFrame {
  std::string section, kind;
  Bytes bytes;
  std::string meaning;
};

const std::vector<ManualFrame>& manual_frames() {
  static const std::vector<ManualFrame> frames = [] {
    std::vector<ManualFrame> out;
    std::ifstream in(std::string(LEC6_TEST_DATA_DIR) + "/manual-frames.tsv");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream row(line);
      ManualFrame f;
      std::string h;
      std::getline(row, f.section, '\t');
      std::getline(row, f.kind, '\t');
      std::getline(row, h, '\t');
      std::getline(row, f.meaning);
      f.bytes = hex(h);
      out.push_back(std::move(f));
    }
    return out;
  }();
  return frames;
}

Bytes manual(std::string_view section, std::string_view kind, int nth = 0) {
  for (const auto& f : manual_frames()) {
    if (f.section == section && f.kind == kind && nth-- == 0) return f.bytes;
  }
  ADD_FAILURE() << "no manual frame " << section << " " << kind;
  return {};
}

Bytes encode(uint8_t id, const modbus::Request& r) {
  return modbus::encode_request({id, r}).value();
}

Bytes raw(Bytes body) {
  modbus::append_crc(body);
  return body;
}

class Line : public ::testing::Test {
 protected:
  explicit Line(LineConfig cfg = {}) : bus(cfg) {}
  void SetUp() override { bus.add(1); }

  // Sends a frame at `t`; returns the reply, and moves `t` past it.
  std::optional<Reply> send(const Bytes& q) {
    auto r = transact(bus, q, t, ms(200));
    t = (r ? r->end : t + bus.line().line.wire_time(q.size()) + ms(200)) + ms(1);
    return r;
  }
  Bytes ask(const Bytes& q) {
    auto r = send(q);
    EXPECT_TRUE(r) << "no reply to " << modbus::to_hex(q);
    return r ? r->bytes : Bytes{};
  }
  void wait(Duration d) {
    t += d;
    bus.advance(t);
  }
  lec::StatusFlags flags(uint8_t id = 1) {
    auto r = modbus::decode_response(
        ask(encode(id, modbus::ReadBitsRequest{modbus::FunctionCode::ReadInputs, 0x40, 16})));
    return lec::StatusFlags::from_packed(std::get<modbus::ReadBitsResponse>(r->pdu).packed);
  }
  std::vector<uint16_t> read(uint16_t start, uint16_t count, uint8_t id = 1) {
    auto r = modbus::decode_response(ask(encode(id, modbus::ReadRegistersRequest{start, count})));
    return std::get<modbus::ReadRegistersResponse>(r->pdu).values;
  }
  std::optional<ExceptionCode> exception_for(const Bytes& q) {
    auto r = modbus::decode_response(ask(q));
    if (!r) return std::nullopt;
    if (auto* e = std::get_if<modbus::ExceptionResponse>(&r->pdu)) {
      EXPECT_EQ(e->raw_function, q[1]);
      return e->code;
    }
    return std::nullopt;
  }

  Bus bus;
  TimePoint t = TimePoint{} + ms(10'000);
};

lec::StepData step_record(int32_t position) {
  lec::StepData s;
  s.movement_mode = lec::MovementMode::Absolute;
  s.speed_mm_s = 500;
  s.position_001mm = position;
  s.acceleration_mm_s2 = 5000;
  s.deceleration_mm_s2 = 5000;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 100;
  return s;
}

// Manual operation examples 1–4 (§4–§7), with the manual's own frames.
TEST_F(Line, ManualOperationExamples) {
  // The library's encoder builds the manual's frames.
  EXPECT_EQ(encode(1, modbus::ReadBitsRequest{modbus::FunctionCode::ReadInputs, 0x40, 16}),
            manual("4.1.3", "query"));
  EXPECT_EQ(encode(1, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}), manual("4.1.1", "query"));
  // 1. Serial mode and servo on: FC05 replies echo the request.
  EXPECT_EQ(ask(manual("4.1.1", "query")), manual("4.1.1", "query"));
  EXPECT_EQ(ask(manual("4.1.2", "query")), manual("4.1.2", "query"));
  wait(ms(50));
  EXPECT_EQ(ask(manual("4.1.3", "query")), manual("4.1.3", "response"));  // 01 02 02 00 02 38 79

  // 2. Return to origin.
  EXPECT_EQ(ask(manual("4.2.1", "query")), manual("4.2.1", "query"));
  wait(ms(600));
  EXPECT_EQ(ask(manual("4.1.3", "query")), manual("4.2.2", "response"));  // 01 02 02 00 0E 38 7C
  EXPECT_EQ(ask(manual("4.2.3", "query")), manual("4.2.3", "query"));

  // 3. Step data No.1: a full record, then the manual's write of its position (150.00 mm).
  const auto regs = step_record(0).to_registers();
  ask(encode(1, modbus::WriteRegistersRequest::of(lec::step_address(1), regs)));
  EXPECT_EQ(ask(manual("5", "query")), raw(hex("01 10 04 12 00 02")));

  // The manual's FC0F (select step 2) answers start and count.
  EXPECT_EQ(ask(manual("4.3", "query", 0)), raw(hex("01 0F 00 10 00 08")));
  // Select step 1, DRIVE with the manual's frames.
  const bool step1[8] = {true};
  ask(encode(1, modbus::WriteCoilsRequest::of(0x10, step1)));
  EXPECT_EQ(ask(manual("4.3", "query", 1)), manual("4.3", "query", 1));
  EXPECT_TRUE(flags().busy());
  for (int i = 0; i < 100 && flags().busy(); ++i) wait(ms(20));
  const auto done = flags();
  EXPECT_FALSE(done.busy());
  EXPECT_TRUE(done.inp());
  EXPECT_EQ(done.out(), 1);
  EXPECT_EQ(ask(manual("4.4", "query")), manual("4.4", "query"));
  // 4. Current position: 01 03 04 00 00 3A 98 E9 39.
  EXPECT_EQ(ask(manual("6", "query")), manual("6", "response"));

  // 5. Direct operation to 300.00 mm with the manual's frames.
  EXPECT_EQ(ask(manual("7.3.1", "query")), raw(hex("01 10 91 02 00 10")));
  EXPECT_EQ(ask(manual("7.3.2", "query")), raw(hex("01 10 91 00 00 01")));
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags().inp());
  wait(ms(700));
  EXPECT_EQ(read(0x9000, 2), (std::vector<uint16_t>{0, 30000}));
  EXPECT_TRUE(flags().inp());
  EXPECT_FALSE(flags().busy());
}

TEST_F(Line, EchoBackExample) {
  bus.add(0x20);
  EXPECT_EQ(ask(manual("11", "query")), manual("11", "query"));
}

TEST_F(Line, EveryExceptionRule) {
  struct Case {
    const char* what;
    Bytes frame;
    ExceptionCode code;
  };
  const std::vector<Case> parallel = {
      {"FC04", raw(hex("01 04 90 00 00 01")), ExceptionCode::IllegalFunction},
      {"FC06", raw(hex("01 06 90 00 00 01")), ExceptionCode::IllegalFunction},
      {"FC2B", raw(hex("01 2B 0E 01 00")), ExceptionCode::IllegalFunction},
      {"read count 0", raw(hex("01 03 90 00 00 00")), ExceptionCode::IllegalAccessRange},
      {"read 126 registers", raw(hex("01 03 04 00 00 7E")), ExceptionCode::IllegalAccessRange},
      {"read 2001 bits", raw(hex("01 01 00 00 07 D1")), ExceptionCode::IllegalAccessRange},
      {"FC0F count 0", raw(hex("01 0F 00 30 00 00 00")), ExceptionCode::IllegalAccessRange},
      {"count 0 outside the map: count first", raw(hex("01 03 00 00 00 00")),
       ExceptionCode::IllegalAccessRange},
      {"start outside every area (D0000)", raw(hex("01 03 00 00 00 01")),
       ExceptionCode::IllegalAddress},
      {"start outside (D8FFF)", raw(hex("01 03 8F FF 00 01")), ExceptionCode::IllegalAddress},
      {"X start outside", raw(hex("01 02 00 30 00 01")), ExceptionCode::IllegalAddress},
      {"Y start outside", raw(hex("01 01 00 40 00 01")), ExceptionCode::IllegalAddress},
      {"end beyond the state area", raw(hex("01 03 90 F0 00 20")),
       ExceptionCode::IllegalAccessRange},
      {"end beyond X4F", raw(hex("01 02 00 40 00 11")), ExceptionCode::IllegalAccessRange},
      {"end beyond the step area", raw(hex("01 03 07 F0 00 11")),
       ExceptionCode::IllegalAccessRange},
      {"write D9000 (read-only)", raw(hex("01 10 90 00 00 01 02 00 00")),
       ExceptionCode::IllegalAddress},
      {"write alarm history", raw(hex("01 10 03 80 00 01 02 00 00")),
       ExceptionCode::IllegalAddress},
      {"write equipment name", raw(hex("01 10 00 0E 00 01 02 41 42")),
       ExceptionCode::IllegalAddress},
      {"write Y31", raw(hex("01 05 00 31 FF 00")), ExceptionCode::IllegalAddress},
      {"write Y00", raw(hex("01 05 00 00 FF 00")), ExceptionCode::IllegalAddress},
      {"parallel mode: Y19", raw(hex("01 05 00 19 FF 00")), ExceptionCode::IllegalAddress},
      {"parallel mode: FC0F Y10", raw(hex("01 0F 00 10 00 08 01 02")),
       ExceptionCode::IllegalAddress},
      {"parallel mode: D90C1", raw(hex("01 10 90 C1 00 01 02 02 00")),
       ExceptionCode::IllegalAddress},
      {"parallel mode: D9100", raw(hex("01 10 91 00 00 01 02 01 00")),
       ExceptionCode::IllegalAddress},
      {"range before permission", raw(hex("01 10 91 11 00 02 04 00 00 00 00")),
       ExceptionCode::IllegalAccessRange},
      {"FC05 value 1234", raw(hex("01 05 00 30 12 34")), ExceptionCode::IllegalAccessRange},
      {"echo test code 0001", raw(hex("01 08 00 01 5A A5")), ExceptionCode::IllegalAddress},
      {"byte count ≠ 2 × count", raw(hex("01 10 91 02 00 02 02 00 01")),
       ExceptionCode::IllegalAccessRange},
      {"byte count ≠ data present", raw(hex("01 10 91 02 00 01 04 00 01")),
       ExceptionCode::IllegalAccessRange},
      {"FC0F byte count ≠ count", raw(hex("01 0F 00 30 00 01 02 01 00")),
       ExceptionCode::IllegalAccessRange},
  };
  for (const auto& c : parallel) EXPECT_EQ(exception_for(c.frame), c.code) << c.what;

  // 257 coils in one FC0F.
  Bytes big = hex("01 0F 00 00 01 01 21");
  big.resize(big.size() + 33, 0);
  EXPECT_EQ(exception_for(raw(big)), ExceptionCode::IllegalAccessRange);

  // What parallel mode accepts: Y30, step data, direct data, D90C2.
  EXPECT_FALSE(exception_for(raw(hex("01 10 91 02 00 01 02 00 01"))));
  EXPECT_FALSE(exception_for(raw(hex("01 10 04 00 00 01 02 00 01"))));
  EXPECT_FALSE(exception_for(raw(hex("01 10 90 C2 00 01 02 00 01"))));  // Y30 ← 1 via the word
  // Now in serial mode the same writes are accepted.
  EXPECT_FALSE(exception_for(raw(hex("01 05 00 19 FF 00"))));
  EXPECT_FALSE(exception_for(raw(hex("01 10 90 C1 00 01 02 02 00"))));
  EXPECT_FALSE(exception_for(raw(hex("01 0F 00 10 00 08 01 00"))));
  // Y16, Y17, Y1F: accepted, no effect.
  EXPECT_FALSE(exception_for(raw(hex("01 05 00 1F FF 00"))));
  // Undefined addresses inside an area read 0 (Y10 × 33, D9100 × 18 as field drivers do).
  EXPECT_FALSE(exception_for(raw(hex("01 01 00 10 00 21"))));
  EXPECT_FALSE(exception_for(raw(hex("01 03 91 00 00 12"))));
}

TEST_F(Line, ExceptionReplyBytes) {
  // [ID][FC|80][code][CRC]
  EXPECT_EQ(ask(raw(hex("01 04 90 00 00 01"))), raw(hex("01 84 01")));
  EXPECT_EQ(ask(raw(hex("01 05 00 19 FF 00"))), raw(hex("01 85 02")));
}

TEST_F(Line, BroadcastWritesWithoutReply) {
  bus.add(2);
  bus.add(3);
  EXPECT_FALSE(send(raw(hex("00 05 00 30 FF 00"))));  // Y30 ← 1 on every controller
  for (uint8_t id : {1, 2, 3}) EXPECT_TRUE(bus.find(id)->control().serial_mode);
  const auto regs = step_record(12345).to_registers();
  EXPECT_FALSE(send(encode(0, modbus::WriteRegistersRequest::of(lec::step_address(7), regs))));
  for (uint8_t id : {1, 2, 3}) EXPECT_EQ(bus.find(id)->eeprom().steps[7].position_001mm, 12345);
  const bool svon[8] = {false, false, false, false, false, false, false, false};
  EXPECT_FALSE(send(encode(0, modbus::WriteCoilsRequest::of(0x10, svon))));
  // Reads and echo are ignored.
  EXPECT_FALSE(send(raw(hex("00 03 90 00 00 02"))));
  EXPECT_FALSE(send(raw(hex("00 08 00 00 5A A5"))));
  EXPECT_EQ(bus.stats().broadcasts, 3u);
  EXPECT_EQ(bus.eeproms().size(), 3u);
  EXPECT_EQ(bus.eeproms().at(2).step_writes[7], 1u);
  EXPECT_GT(bus.eeprom_generation(), 0u);
  EXPECT_EQ(bus.stats().replies, 0u);
}

TEST_F(Line, BadCrcAndOtherIdsAreSilent) {
  Bytes bad = manual("4.1.1", "query");
  bad.back() ^= 0x01;
  EXPECT_FALSE(send(bad));
  EXPECT_FALSE(bus.find(1)->control().serial_mode);
  EXPECT_FALSE(send(raw(hex("09 05 00 30 FF 00"))));
  EXPECT_FALSE(send(hex("01 05")));  // too short
  EXPECT_EQ(bus.stats().bad_frames, 2u);
  EXPECT_EQ(bus.stats().other_ids, 1u);
  // Still answers afterwards.
  EXPECT_EQ(ask(manual("4.1.1", "query")), manual("4.1.1", "query"));
}

TEST_F(Line, SixteenControllersAnswerOnlyTheirOwnId) {
  for (uint8_t id = 2; id <= 16; ++id) bus.add(id);
  bus.add(255);  // 248–255 are valid controller IDs here
  for (uint8_t id : {1, 5, 16, 255}) {
    const Bytes r = ask(encode(id, modbus::ReadRegistersRequest{0x9000, 2}));
    ASSERT_FALSE(r.empty());
    EXPECT_EQ(r[0], id);
  }
  ask(encode(5, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}));
  for (uint8_t id : bus.ids()) EXPECT_EQ(bus.find(id)->control().serial_mode, id == 5) << int(id);
  EXPECT_EQ(bus.ids().size(), 17u);
  EXPECT_THROW(bus.add(5), lec6::InvalidArgument);
  EXPECT_THROW(bus.add(0), lec6::InvalidArgument);
}

TEST_F(Line, StartReplyComesAfterBusyRises) {
  ask(manual("4.1.1", "query"));
  ask(manual("4.1.2", "query"));
  wait(ms(50));
  ask(manual("4.2.1", "query"));
  wait(ms(600));
  EXPECT_TRUE(flags().inp());
  ask(manual("7.3.1", "query"));
  ask(manual("7.3.2", "query"));
  // The very next read after the start reply: BUSY 1, INP 0.
  const auto f = flags();
  EXPECT_TRUE(f.busy());
  EXPECT_FALSE(f.inp());
}

TEST_F(Line, RealTimingReplyEndsAtTheLimit) {
  const Bytes q = manual("4.1.3", "query");
  const modbus::LineTiming& lt = bus.line().line;
  const TimePoint end_of_query = t + lt.wire_time(q.size());
  bus.receive(q, end_of_query);
  EXPECT_EQ(bus.next_deadline(), end_of_query + lt.silent_interval());
  bus.advance(end_of_query + lt.silent_interval() - Duration(1));
  EXPECT_TRUE(bus.take_replies(end_of_query + lt.silent_interval()).empty());
  bus.advance(end_of_query + lt.silent_interval());
  const TimePoint start = end_of_query + lt.silent_interval() + ms(4) + ms(5);
  EXPECT_EQ(bus.next_deadline(), start);
  EXPECT_TRUE(bus.take_replies(start - Duration(1)).empty());
  auto rs = bus.take_replies(start);
  ASSERT_EQ(rs.size(), 1u);
  EXPECT_EQ(rs[0].start, start);
  EXPECT_EQ(rs[0].end - end_of_query, lt.nominal_turnaround(7));
  // 38400 baud, k = 1, Td = 5 ms: 0.911 + 4 + 5 + 1.823 ms.
  EXPECT_NEAR(to_ms(rs[0].end - end_of_query), 11.734, 0.001);
  EXPECT_FALSE(bus.next_deadline());
}

TEST(LineTiming, RealTimingAtOtherSettings) {
  LineConfig cfg;
  cfg.line.baud = 9600;
  cfg.line.silent_interval_k = 3;
  cfg.line.delay_td = std::chrono::milliseconds(12);
  Bus bus(cfg);
  bus.add(1);
  const Bytes q = encode(1, modbus::ReadRegistersRequest{0x9000, 7});
  const TimePoint t0 = TimePoint{} + std::chrono::milliseconds(5);
  auto r = transact(bus, q, t0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->bytes.size(), 19u);
  EXPECT_EQ(r->end - (t0 + cfg.line.wire_time(q.size())), cfg.line.nominal_turnaround(19));
}

TEST(LineTiming, FastTimingHasNoDelay) {
  LineConfig cfg;
  cfg.timing = Timing::Fast;
  Bus bus(cfg);
  bus.add(1);
  const Bytes q = manual("4.1.3", "query");
  const TimePoint end = TimePoint{} + std::chrono::milliseconds(1);
  bus.receive(q, end);
  auto rs = bus.take_replies(end);  // complete on length + CRC: no Ts wait
  ASSERT_EQ(rs.size(), 1u);
  EXPECT_EQ(rs[0].start, end);
  EXPECT_EQ(rs[0].end, end);  // fast timing: no wire time either
  EXPECT_EQ(rs[0].bytes, hex("01 02 02 00 00 B9 B8"));
  // An unknown function cannot be sized: it waits for Ts, then gets exception 01.
  const Bytes odd = raw(hex("01 04 90 00 00 01"));
  bus.receive(odd, end + std::chrono::milliseconds(10));
  EXPECT_TRUE(bus.take_replies(end + std::chrono::milliseconds(10)).empty());
  const TimePoint after = end + std::chrono::milliseconds(10) + cfg.line.silent_interval();
  EXPECT_EQ(bus.next_deadline(), after);
  bus.advance(after);
  rs = bus.take_replies(after);
  ASSERT_EQ(rs.size(), 1u);
  EXPECT_EQ(rs[0].bytes, raw(hex("01 84 01")));
}

TEST_F(Line, FramesAreDelimitedBySilence) {
  const Bytes q = manual("4.1.1", "query");
  const Duration ts = bus.line().line.silent_interval();
  // Split with a gap shorter than Ts: one frame.
  bus.receive(std::span(q).first(3), t);
  bus.receive(std::span(q).subspan(3), t + ts - Duration(1000));
  t += ms(100);
  bus.advance(t);
  EXPECT_EQ(bus.take_replies(t).size(), 1u);
  EXPECT_TRUE(bus.find(1)->control().serial_mode);
  // A gap of Ts: two fragments, both garbage, no reply.
  const Bytes off = raw(hex("01 05 00 30 00 00"));
  bus.receive(std::span(off).first(3), t);
  bus.receive(std::span(off).subspan(3), t + ts);
  t += ms(100);
  bus.advance(t);
  EXPECT_TRUE(bus.take_replies(t).empty());
  EXPECT_TRUE(bus.find(1)->control().serial_mode);
}

TEST(Faults, EachFaultAltersTheReply) {
  const Bytes q = manual("4.1.3", "query");
  const Bytes good = hex("01 02 02 00 00 B9 B8");
  auto run = [&](const FaultConfig& f) {
    Bus bus({}, f);
    bus.add(1);
    return transact(bus, q, TimePoint{});
  };
  auto clean = run({});
  ASSERT_TRUE(clean);
  EXPECT_EQ(clean->bytes, good);

  FaultConfig drop;
  drop.drop = 1.0;
  EXPECT_FALSE(run(drop));

  FaultConfig corrupt;
  corrupt.corrupt = 1.0;
  auto c = run(corrupt);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->bytes.size(), good.size());
  EXPECT_NE(c->bytes, good);
  EXPECT_FALSE(modbus::crc_ok(c->bytes));

  FaultConfig garbage;
  garbage.garbage = 1.0;
  auto g = run(garbage);
  ASSERT_TRUE(g);
  ASSERT_GT(g->bytes.size(), good.size());
  EXPECT_LE(g->bytes.size(), good.size() + garbage.garbage_max_bytes);
  EXPECT_TRUE(std::equal(good.rbegin(), good.rend(), g->bytes.rbegin()));

  FaultConfig delay;
  delay.delay = 1.0;
  delay.extra_delay = std::chrono::milliseconds(50);
  auto d = run(delay);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->start - clean->start, std::chrono::milliseconds(50));
  EXPECT_EQ(d->bytes, good);
}

TEST(Faults, SeededAndReproducible) {
  FaultConfig f;
  f.drop = 0.3;
  f.corrupt = 0.3;
  f.seed = 42;
  auto run = [&] {
    Bus bus({}, f);
    bus.add(1);
    std::vector<std::optional<Bytes>> out;
    TimePoint t{};
    for (int i = 0; i < 50; ++i) {
      auto r = transact(bus, manual("4.1.3", "query"), t, std::chrono::milliseconds(100));
      out.push_back(r ? std::optional<Bytes>(r->bytes) : std::nullopt);
      t += std::chrono::milliseconds(200);
    }
    return std::pair{out, bus.stats()};
  };
  auto [a, sa] = run();
  auto [b, sb] = run();
  EXPECT_EQ(a, b);
  EXPECT_GT(sa.faults_dropped, 5u);
  EXPECT_GT(sa.faults_corrupted, 5u);
  EXPECT_EQ(sa.faults_dropped, sb.faults_dropped);
}

}  // namespace
}  // namespace lec6::sim
