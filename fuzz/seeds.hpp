#pragma once
// Seed inputs for the fuzz harnesses (harness.hpp), built from the manual's
// golden frames (tests/data/manual-frames.tsv) and from what the twin answers
// to them. fuzz/make_seeds writes them to corpus directories; the regression
// test runs every one of them through its harness.

#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_table.hpp"
#include "lec6/modbus/capture.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::fuzz {

struct Golden {
  std::string section;
  bool query = false;
  modbus::Bytes bytes;
};

// The TSV: section<TAB>kind<TAB>hex<TAB>meaning, '#' comments.
inline std::vector<Golden> parse_golden(const std::string& tsv) {
  std::vector<Golden> out;
  std::istringstream in(tsv);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Golden g;
    std::string kind, hex;
    std::getline(fields, g.section, '\t');
    std::getline(fields, kind, '\t');
    std::getline(fields, hex, '\t');
    auto bytes = modbus::from_hex(hex);
    if (!bytes) continue;
    g.query = kind == "query";
    g.bytes = std::move(*bytes);
    out.push_back(std::move(g));
  }
  return out;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

using Seed = std::pair<std::string, modbus::Bytes>;  // name, content

namespace detail {

inline modbus::Bytes frame(uint8_t id, const modbus::Request& r) {
  return *modbus::encode_request({id, r});
}

// Golden queries plus a few more the client sends, in a sensible order.
inline std::vector<modbus::Bytes> queries(const std::vector<Golden>& golden) {
  std::vector<modbus::Bytes> q;
  for (const auto& g : golden) {
    if (g.query) q.push_back(g.bytes);
  }
  using namespace modbus;
  q.push_back(frame(1, ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}));
  q.push_back(frame(1, ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 33}));
  q.push_back(frame(1, ReadRegistersRequest{lec::kAlarmHistory, lec::kAlarmHistoryRegisters}));
  q.push_back(frame(1, ReadRegistersRequest{lec::kEquipmentName, lec::kEquipmentNameRegisters}));
  q.push_back(frame(1, ReadRegistersRequest{lec::kStepData, 112}));
  q.push_back(frame(1, ReadRegistersRequest{0x2000, 1}));  // outside the map: exception 02
  q.push_back(frame(2, EchoRequest{0, 0x1234}));
  return q;
}

// The twin's replies to `qs`, sent in order to one twin (fast timing).
inline std::vector<modbus::Bytes> twin_replies(const std::vector<modbus::Bytes>& qs) {
  sim::LineConfig line;
  line.timing = sim::Timing::Fast;
  sim::Bus bus(line);
  TimePoint t = TimePoint{} + std::chrono::seconds(1);
  bus.add(1, {}, t);
  bus.add(2, {}, t);
  bus.add(32, {}, t);
  std::vector<modbus::Bytes> out;
  for (const auto& q : qs) {
    auto r = sim::transact(bus, q, t);
    t += std::chrono::seconds(2);
    out.push_back(r ? r->bytes : modbus::Bytes{});
  }
  return out;
}

inline modbus::Bytes cat(std::initializer_list<modbus::Bytes> parts) {
  modbus::Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

}  // namespace detail

// Seeds for harness "reply", "request", "twin" or "steps". `tsv` is the
// golden frames file's text; `steps_dir` holds sample step tables.
inline std::vector<Seed> make_seeds(const std::string& harness, const std::string& tsv,
                                    const std::string& steps_dir = {}) {
  const auto golden = parse_golden(tsv);
  const auto qs = detail::queries(golden);
  std::vector<Seed> seeds;
  auto add = [&](std::string name, modbus::Bytes b) {
    seeds.emplace_back(std::move(name), std::move(b));
  };

  if (harness == "reply") {
    const auto rs = detail::twin_replies(qs);
    for (std::size_t i = 0; i < qs.size(); ++i) {
      if (rs[i].empty()) continue;
      add("twin-" + std::to_string(i), detail::cat({{0}, qs[i], rs[i]}));
      // The same reply behind noise, and split in odd chunks.
      add("noisy-" + std::to_string(i),
          detail::cat({{0x5A}, qs[i], {0x00, 0xFF, qs[i][0]}, rs[i]}));
    }
    // The manual's query/reply pairs.
    for (std::size_t i = 0; i + 1 < golden.size(); ++i) {
      if (golden[i].query && !golden[i + 1].query && golden[i].section == golden[i + 1].section) {
        add("manual-" + golden[i].section,
            detail::cat({{0}, golden[i].bytes, golden[i + 1].bytes}));
      }
    }
    for (const auto& g : golden) {
      if (!g.query) add("reply-only-" + g.section, detail::cat({{0}, g.bytes}));
    }
  } else if (harness == "request") {
    modbus::Bytes all{0};
    for (std::size_t i = 0; i < qs.size(); ++i) {
      add("query-" + std::to_string(i), detail::cat({{0}, qs[i]}));
      add("query-fast-" + std::to_string(i), detail::cat({{4}, qs[i]}));
      all.insert(all.end(), qs[i].begin(), qs[i].end());
    }
    add("all-queries", all);
    for (const auto& g : golden) {
      if (!g.query) add("reply-as-query-" + g.section, detail::cat({{1}, g.bytes}));
    }
  } else if (harness == "twin") {
    // The manual's operation examples in order, with time for SVRE, homing and motion.
    auto record = [](uint8_t head, const modbus::Bytes& body) {
      modbus::Bytes r{head, static_cast<uint8_t>(body.size())};
      r.insert(r.end(), body.begin(), body.end());
      return r;
    };
    for (uint8_t setup : {0x00, 0x01, 0x02, 0x0B}) {
      modbus::Bytes whole{setup}, fixed{setup};
      for (const auto& q : qs) {
        const auto rec = record(0x10, q);  // 2 ms gap: a frame of its own
        whole.insert(whole.end(), rec.begin(), rec.end());
        const auto rec2 =
            record(0x90, modbus::Bytes(q.begin(), q.end() - 2));  // CRC by the harness
        fixed.insert(fixed.end(), rec2.begin(), rec2.end());
        const auto wait = record(0x40, {});  // 2 s: SVRE, homing, a move
        whole.insert(whole.end(), wait.begin(), wait.end());
        fixed.insert(fixed.end(), wait.begin(), wait.end());
      }
      add("manual-sequence-" + std::to_string(setup), whole);
      add("manual-sequence-crc-" + std::to_string(setup), fixed);
    }
    // A day at the machine: prepare, run a step with HOLD and resume, a
    // direct move beyond the stroke (alarm), RESET, jog, a relative move,
    // servo off, EMG stop. Bodies without CRC: the harness adds it.
    {
      using namespace modbus;
      auto body = [](const Request& r) {
        auto f = detail::frame(1, r);
        return modbus::Bytes(f.begin(), f.end() - 2);
      };
      auto coil = [&](uint16_t c, bool on) {
        return body(WriteCoilRequest{c, on ? kCoilOn : kCoilOff});
      };
      const uint16_t good[16] = {1, 500, 0, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 0, 0, 0, 100};
      const uint16_t beyond[16] = {1,  500, 0x0089, 0x5440, 5000, 5000, 0, 0,
                                   20, 100, 0,      0,      0,    0,    0, 100};
      const uint16_t inc[16] = {2,  200, 0xFFFF, 0xEC78, 3000, 3000, 0, 0,
                                20, 100, 0,      0,      0,    0,    0, 50};
      const bool step1[8] = {true, false, false, false, false, false, false, false};
      const std::vector<uint16_t> start{0x0100};
      const std::vector<std::pair<uint8_t, modbus::Bytes>> day = {
          {0x90, coil(0x30, true)},
          {0x90, coil(0x19, true)},
          {0xB0, coil(0x1C, true)},
          {0xC0, {}},
          {0x90, coil(0x1C, false)},
          {0x90, body(WriteRegistersRequest::of(0x0410, good))},
          {0x90, body(WriteCoilsRequest::of(0x10, step1))},
          {0x90, coil(0x1A, true)},
          {0xB0, coil(0x18, true)},
          {0xB0, coil(0x18, false)},
          {0xC0, coil(0x1A, false)},
          {0x90, body(WriteRegistersRequest::of(0x9102, beyond))},
          {0x90, body(WriteRegistersRequest::of(0x9100, start))},
          {0xB0, body(ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16})},
          {0x90, coil(0x1B, true)},
          {0x90, coil(0x1B, false)},
          {0x90, coil(0x1E, true)},
          {0xB0, coil(0x1E, false)},
          {0x90, body(WriteRegistersRequest::of(0x9102, inc))},
          {0x90, body(WriteRegistersRequest::of(0x9100, start))},
          {0xC0, body(ReadRegistersRequest{0x9000, 7})},
          {0x90, body(ReadRegistersRequest{0x0380, 64})},
          {0x90, coil(0x19, false)},
          {0x60, {}},
          {0x90, body(ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16})},
      };
      for (uint8_t setup : {0x00, 0x03, 0x04}) {
        modbus::Bytes seq{setup};
        for (const auto& [head, b] : day) {
          const auto r = record(head, b);
          seq.insert(seq.end(), r.begin(), r.end());
        }
        add("a-day-at-the-machine-" + std::to_string(setup), seq);
      }
    }
    // A pushing move against the workpiece, then an emergency stop.
    {
      using namespace modbus;
      const uint16_t push[16] = {1,  100, 0, 20000, 3000, 3000, 50, 40,
                                 10, 100, 0, 0,     0,    0,    0,  10000};
      modbus::Bytes s{0x02};
      for (const auto& q : {detail::frame(1, WriteCoilRequest{0x30, kCoilOn}),
                            detail::frame(1, WriteCoilRequest{0x19, kCoilOn}),
                            detail::frame(1, WriteCoilRequest{0x1C, kCoilOn})}) {
        const auto rec = record(0x40, q);
        s.insert(s.end(), rec.begin(), rec.end());
      }
      for (const auto& q :
           {detail::frame(1, WriteCoilRequest{0x1C, kCoilOff}),
            detail::frame(1, WriteRegistersRequest::of(0x9102, push)),
            detail::frame(1, WriteRegistersRequest::of(0x9100, std::vector<uint16_t>{0x0100}))}) {
        const auto rec = record(0x40, q);
        s.insert(s.end(), rec.begin(), rec.end());
      }
      const auto estop =
          record(0x60, detail::frame(1, ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16}));
      s.insert(s.end(), estop.begin(), estop.end());
      add("push-then-estop", s);
    }
  } else if (harness == "steps") {
    for (const char* name :
         {"bad_row.csv", "duplicate_step.csv", "press2.json", "reordered_columns.csv",
          "semicolon_decimal_comma.csv", "spreadsheet_saved.csv", "unknown_column.csv"}) {
      if (steps_dir.empty()) break;
      const std::string text = read_file(steps_dir + "/" + name);
      if (!text.empty()) add(name, modbus::Bytes(text.begin(), text.end()));
    }
    lec::StepTable t;
    t.equipment_name = "LEC6-AXIS1";
    t.controller_id = 1;
    t.steps[0] = {lec::MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};
    t.steps[1] = {
        lec::MovementMode::Incremental, 100, -1250, 3000, 3000, 50, 30, 10, 100, -500, 500, 2000};
    t.covered.reset();
    t.covered.set(0);
    t.covered.set(1);
    t.covered.set(2);
    const std::string csv = lec::to_csv(t);
    const std::string json = lec::to_json(t);
    add("written.csv", modbus::Bytes(csv.begin(), csv.end()));
    add("written.json", modbus::Bytes(json.begin(), json.end()));
  }
  if (harness == "sniff") {
    // What a second adapter hears: queries and the twin's replies, back to
    // back, alone, behind noise, and the whole session as one stream; and a
    // capture file's text (the same bytes are read as one).
    const auto rs = detail::twin_replies(qs);
    modbus::Bytes session{0x06};
    for (std::size_t i = 0; i < qs.size(); ++i) {
      add("exchange-" + std::to_string(i), detail::cat({{static_cast<uint8_t>(i)}, qs[i], rs[i]}));
      add("noisy-" + std::to_string(i),
          detail::cat({{static_cast<uint8_t>(i + 1)}, {0x00, 0xFF, qs[i][0]}, qs[i], rs[i]}));
      session.insert(session.end(), qs[i].begin(), qs[i].end());
      session.insert(session.end(), rs[i].begin(), rs[i].end());
    }
    add("session", session);
    modbus::CaptureHeader h;
    h.source = "sniff";
    h.started_utc = "2026-11-24T19:00:00.000000Z";
    std::string text = modbus::encode_capture_header(h);
    int64_t t = 0;
    for (std::size_t i = 0; i < qs.size() && i < 8; ++i) {
      modbus::CaptureRecord r;
      r.t_us = t;
      r.end_us = t + 2000;
      r.dir = modbus::CaptureDir::Query;
      r.bytes = qs[i];
      text += modbus::encode_capture_record(r);
      t += 20000;
    }
    add("capture.jsonl", detail::cat({{0}, modbus::Bytes(text.begin(), text.end())}));
  }
  return seeds;
}

inline const std::vector<std::string>& harness_names() {
  static const std::vector<std::string> names = {"reply", "request", "twin", "steps", "sniff"};
  return names;
}

}  // namespace lec6::fuzz
