// The fidelity report of a replay (include/lec6/twin/replay.hpp): pairing a
// capture's records into exchanges, and setting replayed replies beside the
// captured ones, value by value, in the manual's terms.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

#include "lec6/error.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/twin/replay.hpp"

namespace lec6::twin {
namespace {

bool sound_frame(const modbus::Bytes& b) {
  return b.size() >= 4 && modbus::decode_response(b).has_value();
}

// X40–X4F as the manual names them.
constexpr std::array<const char*, 16> kInputNames{"OUT0", "OUT1",  "OUT2",  "OUT3", "OUT4",  "OUT5",
                                                  "X46",  "X47",   "BUSY",  "SVRE", "SETON", "INP",
                                                  "AREA", "WAREA", "ESTOP", "ALARM"};

enum class ValueKind { Discrete, Position, Speed, Thrust };

struct Value {
  std::string name;
  ValueKind kind = ValueKind::Discrete;
  int64_t raw = 0;
  std::string shown;
};

int32_t join(uint16_t hi, uint16_t lo) {
  return static_cast<int32_t>((uint32_t{hi} << 16) | lo);
}

// The values a reply carries, named; empty when it does not decode as the
// reply to that request (then the bytes are compared).
std::optional<std::vector<Value>> values_of(const modbus::Bytes& query,
                                            const modbus::Bytes& reply) {
  auto q = modbus::decode_request(query);
  auto r = modbus::decode_response(reply);
  if (!q || !r) return std::nullopt;
  std::vector<Value> out;
  if (auto* e = std::get_if<modbus::ExceptionResponse>(&r->pdu)) {
    out.push_back({"exception", ValueKind::Discrete, static_cast<int64_t>(e->code),
                   fmt::format("{:02X} ({})", static_cast<unsigned>(e->code),
                               modbus::exception_name(e->code))});
    return out;
  }
  if (auto* bits = std::get_if<modbus::ReadBitsRequest>(&q->pdu)) {
    auto* rb = std::get_if<modbus::ReadBitsResponse>(&r->pdu);
    if (!rb) return std::nullopt;
    const bool inputs = bits->function == modbus::FunctionCode::ReadInputs;
    for (uint16_t i = 0; i < bits->count; ++i) {
      const unsigned a = bits->start + i;
      std::string name = fmt::format("{}{:02X}", inputs ? "X" : "Y", a);
      if (inputs && a >= lec::kStatusInputs && a < lec::kStatusInputs + 16u)
        name += fmt::format(" {}", kInputNames[a - lec::kStatusInputs]);
      const bool on = rb->bit(i);
      out.push_back({name, ValueKind::Discrete, on ? 1 : 0, on ? "1" : "0"});
    }
    return out;
  }
  if (auto* regs = std::get_if<modbus::ReadRegistersRequest>(&q->pdu)) {
    auto* rr = std::get_if<modbus::ReadRegistersResponse>(&r->pdu);
    if (!rr) return std::nullopt;
    const auto& v = rr->values;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const unsigned a = regs->start + static_cast<unsigned>(i);
      if ((a == 0x9000 || a == 0x9004) && i + 1 < v.size()) {
        const int32_t p = join(v[i], v[i + 1]);
        const bool position = a == 0x9000;
        out.push_back({position ? "D9000 position" : "D9004 target",
                       position ? ValueKind::Position : ValueKind::Discrete, p,
                       lec::format_mm(p) + " mm"});
        ++i;
      } else if (a == 0x9002) {
        out.push_back({"D9002 speed", ValueKind::Speed, v[i], fmt::format("{} mm/s", v[i])});
      } else if (a == 0x9003) {
        out.push_back({"D9003 thrust", ValueKind::Thrust, v[i], fmt::format("{} %", v[i])});
      } else {
        out.push_back({fmt::format("D{:04X}", a), ValueKind::Discrete, v[i],
                       fmt::format("{} (0x{:04X})", v[i], v[i])});
      }
    }
    return out;
  }
  // Writes and echo: the reply is an echo or a start and count; compare it whole.
  out.push_back({"reply", ValueKind::Discrete, 0, modbus::to_hex(reply)});
  return out;
}

double tolerance_of(ValueKind k, const ReplayTolerance& t) {
  switch (k) {
    case ValueKind::Position:
      return t.position_mm * 100.0;  // raw 0.01 mm
    case ValueKind::Speed:
      return t.speed_mm_s;
    case ValueKind::Thrust:
      return t.thrust_pct;
    case ValueKind::Discrete:
      break;
  }
  return 0;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (pos - static_cast<double>(lo));
}

}  // namespace

std::vector<LineRecord> line_records(const modbus::Capture& capture) {
  std::vector<LineRecord> out;
  out.reserve(capture.records.size());
  for (std::size_t i = 0; i < capture.records.size(); ++i) {
    const auto& r = capture.records[i];
    LineRecord l;
    switch (r.dir) {
      case modbus::CaptureDir::Query:
        l.kind = LineRecord::Kind::Query;
        break;
      case modbus::CaptureDir::Reply:
        l.kind = LineRecord::Kind::Reply;
        break;
      case modbus::CaptureDir::Noise:
        l.kind = LineRecord::Kind::Noise;
        break;
      case modbus::CaptureDir::Unknown:
        l.kind = LineRecord::Kind::Unknown;
        break;
    }
    l.t_us = r.t_us;
    l.end_us = r.end_us;
    l.bytes = r.bytes;
    l.line = i + 2;
    out.push_back(std::move(l));
  }
  return out;
}

void check_replayable(const modbus::Capture& capture, std::string_view file_name) {
  std::size_t queries = 0;
  for (std::size_t i = 0; i < capture.records.size(); ++i) {
    const auto& r = capture.records[i];
    if (r.dir != modbus::CaptureDir::Query) continue;
    ++queries;
    auto q = modbus::decode_request(r.bytes);
    if (!q) {
      throw InvalidArgument(
          fmt::format("{}, line {} (record {}): the query {} is not a Modbus RTU request ({}); "
                      "nothing was sent",
                      file_name, i + 2, i + 1, modbus::to_hex(r.bytes), q.error().message));
    }
  }
  if (queries == 0)
    throw InvalidArgument(
        fmt::format("{}: the capture holds no query to replay (no record with \"dir\": \"query\"); "
                    "nothing was sent",
                    file_name));
}

std::vector<Exchange> pair_exchanges(std::span<const LineRecord> records) {
  std::vector<Exchange> out;
  bool open = false;  // the last exchange still waits for its reply
  for (const auto& r : records) {
    switch (r.kind) {
      case LineRecord::Kind::Query: {
        Exchange e;
        e.line = r.line;
        e.query = r.bytes;
        e.query_start_us = r.t_us;
        e.query_end_us = r.end_us;
        out.push_back(std::move(e));
        open = true;
        break;
      }
      case LineRecord::Kind::Reply:
      case LineRecord::Kind::Unknown:
        if (!open) break;
        if (r.kind == LineRecord::Kind::Unknown && !sound_frame(r.bytes)) break;
        out.back().reply = r.bytes;
        out.back().reply_start_us = r.t_us;
        out.back().reply_end_us = r.end_us;
        open = false;
        break;
      case LineRecord::Kind::Noise:
        break;
    }
  }
  return out;
}

ResponseStats response_stats(std::span<const Exchange> exchanges) {
  std::vector<double> ms;
  for (const auto& e : exchanges) {
    if (auto r = e.response_us()) ms.push_back(static_cast<double>(*r) / 1000.0);
  }
  ResponseStats s;
  s.count = ms.size();
  if (ms.empty()) return s;
  s.p50_ms = percentile(ms, 0.50);
  s.p95_ms = percentile(ms, 0.95);
  s.max_ms = *std::max_element(ms.begin(), ms.end());
  return s;
}

std::string ValueDifference::text() const {
  std::string s = fmt::format("line {}, {:.3f} s: {}: captured {}, twin {}", line,
                              static_cast<double>(at_us) / 1e6, what, captured, replayed);
  if (edge)
    s += " (an edge within tolerance: the twin shows it at a neighbouring exchange)";
  else if (motion)
    s += within_tolerance ? " (within tolerance)" : " (beyond tolerance)";
  return s;
}

namespace {

// Whether the twin shows `name` = `raw` at another exchange whose query starts
// within `edge_us` of exchange i: the flag's edge fell on the other side of a
// poll, not a different behaviour.
bool twin_shows_nearby(std::span<const Exchange> captured,
                       const std::vector<std::optional<std::vector<Value>>>& twin_values,
                       std::size_t i, const std::string& name, int64_t raw, int64_t edge_us) {
  if (edge_us <= 0) return false;
  const int64_t t = captured[i].query_start_us;
  auto shows = [&](std::size_t j) {
    if (!twin_values[j]) return false;
    for (const auto& v : *twin_values[j])
      if (v.name == name) return v.raw == raw;
    return false;
  };
  for (std::size_t j = i; j-- > 0 && t - captured[j].query_start_us <= edge_us;)
    if (shows(j)) return true;
  for (std::size_t j = i + 1; j < captured.size() && captured[j].query_start_us - t <= edge_us; ++j)
    if (shows(j)) return true;
  return false;
}

}  // namespace

FidelityReport compare(std::span<const Exchange> captured, std::span<const Exchange> replayed,
                       const ReplayTolerance& tolerance) {
  // Every twin reply's values, for the edge rule (a flag seen at a
  // neighbouring exchange).
  std::vector<std::optional<std::vector<Value>>> twin_values(captured.size());
  for (std::size_t i = 0; i < captured.size() && i < replayed.size(); ++i)
    if (replayed[i].reply) twin_values[i] = values_of(captured[i].query, *replayed[i].reply);
  const auto edge_us = static_cast<int64_t>(std::llround(tolerance.edge_ms * 1000.0));
  FidelityReport rep;
  rep.tolerance = tolerance;
  rep.exchanges = captured.size();
  const int64_t t0 = captured.empty() ? 0 : captured.front().query_start_us;
  for (std::size_t i = 0; i < captured.size(); ++i) {
    const Exchange& c = captured[i];
    const Exchange* r = i < replayed.size() ? &replayed[i] : nullptr;
    auto diff = [&](std::string what, std::string cap, std::string twin) {
      ValueDifference d;
      d.exchange = i;
      d.line = c.line;
      d.at_us = c.query_start_us - t0;
      d.what = std::move(what);
      d.captured = std::move(cap);
      d.replayed = std::move(twin);
      return d;
    };
    const std::optional<modbus::Bytes> twin_reply = r ? r->reply : std::nullopt;
    if (!c.reply && !twin_reply) {
      ++rep.identical;
      continue;
    }
    if (!c.reply || !twin_reply) {
      rep.differences.push_back(
          diff("reply", c.reply ? modbus::to_hex(*c.reply) : "no reply",
               twin_reply ? modbus::to_hex(*twin_reply) : (r ? "no reply" : "not replayed")));
      ++rep.differing;
      continue;
    }
    if (*c.reply == *twin_reply) {
      ++rep.identical;
      continue;
    }
    const auto cv = values_of(c.query, *c.reply);
    const auto tv = values_of(c.query, *twin_reply);
    bool comparable = cv && tv && cv->size() == tv->size();
    for (std::size_t k = 0; comparable && k < cv->size(); ++k)
      comparable = (*cv)[k].name == (*tv)[k].name;
    if (!comparable) {
      rep.differences.push_back(
          diff("reply bytes", modbus::to_hex(*c.reply), modbus::to_hex(*twin_reply)));
      ++rep.differing;
      continue;
    }
    bool beyond = false;
    for (std::size_t k = 0; k < cv->size(); ++k) {
      const Value& a = (*cv)[k];
      const Value& b = (*tv)[k];
      if (a.raw == b.raw && a.shown == b.shown) continue;
      auto d = diff(a.name, a.shown, b.shown);
      d.motion = a.kind != ValueKind::Discrete;
      const double delta = std::abs(static_cast<double>(a.raw - b.raw));
      d.within_tolerance = d.motion && delta <= tolerance_of(a.kind, tolerance) + 1e-9;
      if (!d.motion && twin_shows_nearby(captured, twin_values, i, a.name, a.raw, edge_us))
        d.edge = d.within_tolerance = true;
      if (a.kind == ValueKind::Position)
        rep.max_position_delta_mm = std::max(rep.max_position_delta_mm, delta / 100.0);
      beyond = beyond || !d.within_tolerance;
      rep.differences.push_back(std::move(d));
    }
    ++(beyond ? rep.differing : rep.within_tolerance);
  }
  rep.captured_response = response_stats(captured);
  rep.replayed_response = response_stats(replayed);
  std::vector<double> ratios;
  for (std::size_t i = 0; i < captured.size() && i < replayed.size(); ++i) {
    const auto c = captured[i].response_us();
    const auto r = replayed[i].response_us();
    if (c && r && *c > 0) ratios.push_back(static_cast<double>(*r) / static_cast<double>(*c));
  }
  if (!ratios.empty()) {
    rep.response_paired_change = percentile(ratios, 0.5) - 1.0;
    rep.response_time_matches = std::abs(rep.response_paired_change) <= tolerance.response_ratio;
  } else {
    rep.response_time_matches = rep.captured_response.count == 0;
  }
  return rep;
}

std::string FidelityReport::text(std::size_t max_lines) const {
  std::string s = fmt::format("replay of {} exchanges against {} (timing {}): {}\n", exchanges,
                              target, timing == ReplayTiming::AsCaptured ? "as-captured" : "fast",
                              matches() ? "matches" : "differs");
  s += fmt::format(
      "  identical {}, motion within tolerance {} (position ±{:.2f} mm, speed ±{:g} mm/s, thrust "
      "±{:g} %{}), differing {}\n",
      identical, within_tolerance, tolerance.position_mm, tolerance.speed_mm_s,
      tolerance.thrust_pct,
      tolerance.edge_ms > 0 ? fmt::format(", flag edges ±{:g} ms", tolerance.edge_ms) : "",
      differing);
  if (max_position_delta_mm > 0)
    s += fmt::format("  largest position difference: {:.2f} mm\n", max_position_delta_mm);
  const auto& c = captured_response;
  const auto& r = replayed_response;
  s += fmt::format(
      "  response time: captured p50 {:.1f} ms (p95 {:.1f}), {} p50 {:.1f} ms (p95 {:.1f}); "
      "exchange by exchange {:+.1f} % (median, {} ±{:.0f} %)\n",
      c.p50_ms, c.p95_ms, target, r.p50_ms, r.p95_ms, 100.0 * response_paired_change,
      response_time_matches ? "within" : "beyond", 100.0 * tolerance.response_ratio);
  std::size_t shown = 0;
  for (const auto& d : differences) {
    if (d.within_tolerance) continue;
    if (shown == 0) s += "differences:\n";
    if (shown++ == max_lines) {
      s += "  …\n";
      break;
    }
    s += "  " + d.text() + "\n";
  }
  return s;
}

std::string FidelityReport::json() const {
  nlohmann::json diffs = nlohmann::json::array();
  for (const auto& d : differences) {
    diffs.push_back({{"exchange", d.exchange},
                     {"line", d.line},
                     {"at_s", static_cast<double>(d.at_us) / 1e6},
                     {"what", d.what},
                     {"captured", d.captured},
                     {"twin", d.replayed},
                     {"motion", d.motion},
                     {"edge", d.edge},
                     {"within_tolerance", d.within_tolerance}});
  }
  auto stats = [](const ResponseStats& s) {
    return nlohmann::json{
        {"count", s.count}, {"p50_ms", s.p50_ms}, {"p95_ms", s.p95_ms}, {"max_ms", s.max_ms}};
  };
  nlohmann::json j{{"target", target},
                   {"timing", timing == ReplayTiming::AsCaptured ? "as-captured" : "fast"},
                   {"matches", matches()},
                   {"exchanges", exchanges},
                   {"identical", identical},
                   {"within_tolerance", within_tolerance},
                   {"differing", differing},
                   {"tolerance",
                    {{"position_mm", tolerance.position_mm},
                     {"speed_mm_s", tolerance.speed_mm_s},
                     {"thrust_pct", tolerance.thrust_pct},
                     {"response_ratio", tolerance.response_ratio},
                     {"edge_ms", tolerance.edge_ms}}},
                   {"max_position_delta_mm", max_position_delta_mm},
                   {"response_time",
                    {{"captured", stats(captured_response)},
                     {"twin", stats(replayed_response)},
                     {"paired_change", response_paired_change},
                     {"matches", response_time_matches}}},
                   {"differences", diffs}};
  return j.dump(2);
}

}  // namespace lec6::twin
