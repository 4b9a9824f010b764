#include "cli/sniff_output.hpp"

#include <unistd.h>

#include <optional>
#include <string>

#include <fmt/color.h>

#include "cli/app.hpp"
#include "lec6/lec/explain.hpp"

namespace lec6::cli {
namespace {

using modbus::SniffEvent;
using modbus::SniffKind;

double ms(Duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

int64_t us(Duration d) {
  return std::chrono::duration_cast<std::chrono::microseconds>(d).count();
}

// Standard Modbus functions a master sends that the LEC does not have (it
// answers exception 01), named with what they ask (issue 33: mbpoll, HMIs and a
// field driver write one register with FC06). nullopt: not one of these.
std::optional<std::string> foreign_function(const modbus::Bytes& b, bool reply) {
  if (b.size() != 8) return std::nullopt;
  const unsigned address = static_cast<unsigned>(b[2] << 8 | b[3]);
  const unsigned word = static_cast<unsigned>(b[4] << 8 | b[5]);
  switch (b[1]) {
    case 0x06:
      return reply ? fmt::format(
                         "ID {} write single register (06h) echo: D{:04X} = {:04X}h ({}) "
                         "(a gateway's or another device's reply: the LEC has no FC06)",
                         b[0], address, word, word)
                   : fmt::format(
                         "ID {} write single register (06h) D{:04X} <- {:04X}h ({}): not "
                         "a function of the LEC (it answers exception 01; lec serve's "
                         "gateway writes it as FC10)",
                         b[0], address, word, word);
    case 0x04:
      if (reply) return std::nullopt;
      return fmt::format(
          "ID {} read input registers (04h) {:04X}h x{}: not a function of the LEC "
          "(it answers exception 01)",
          b[0], address, word);
    default:
      return std::nullopt;
  }
}

// A frame of a function code no table sizes (framed by its CRC).
std::string unknown_function(const SniffEvent& e) {
  const bool reply = e.kind == SniffKind::Reply;
  return fmt::format(
      "ID {} unknown function {:02X}h {}, {} bytes: not a function of the LEC nor one lec6 "
      "sizes; framed by its CRC{}",
      e.bytes[0], e.bytes[1], reply ? "reply" : "query", e.bytes.size(),
      reply ? "" : " (the LEC answers exception 01)");
}

std::string explain(const SniffEvent& e) {
  if (e.has(modbus::kSniffUnknownFunction)) return unknown_function(e);
  switch (e.kind) {
    case SniffKind::Query: {
      if (const auto q = modbus::decode_request(e.bytes)) return lec::explain_request(*q);
      if (auto named = foreign_function(e.bytes, false)) return *named;
      // A sound frame the LEC would refuse (a function it does not have, a bad count).
      return fmt::format("ID {} function {:02X}h: {}", e.bytes[0], e.bytes[1],
                         lec::explain_bytes(e.bytes, lec::FrameRole::Request));
    }
    case SniffKind::Reply: {
      const auto reply = modbus::decode_response(e.bytes);
      const auto query = modbus::decode_request(e.query);
      if (reply && query) return lec::explain_response(*reply, &*query);
      if (reply) return lec::explain_response(*reply);
      if (auto named = foreign_function(e.bytes, true)) return *named;
      return fmt::format("ID {} function {:02X}h: {}", e.bytes[0], e.bytes[1],
                         lec::explain_bytes(e.bytes, lec::FrameRole::Reply));
    }
    case SniffKind::Noise:
      return fmt::format("noise, {} byte{}{}", e.bytes.size(), e.bytes.size() == 1 ? "" : "s",
                         e.has(modbus::kSniffBadCrc) ? " (a frame's start; its CRC failed)" : "");
    case SniffKind::NoReply:
      return fmt::format("no reply from ID {} to query #{}", e.bytes[0], e.query_number);
  }
  return {};
}

std::string_view kind_name(SniffKind k) {
  switch (k) {
    case SniffKind::Query:
      return "query";
    case SniffKind::Reply:
      return "reply";
    case SniffKind::Noise:
      return "noise";
    case SniffKind::NoReply:
      return "no_reply";
  }
  return "noise";
}

// The ID, function and address range a frame concerns (a reply: its query's).
struct Subject {
  unsigned id = 0;
  unsigned function = 0;
  std::optional<std::pair<unsigned, unsigned>> addresses;  // [first, last]
};

Subject subject_of(const SniffEvent& e) {
  Subject s;
  const modbus::Bytes& q = e.kind == SniffKind::Reply && !e.query.empty() ? e.query : e.bytes;
  s.id = e.bytes[0];
  s.function = e.bytes.size() > 1 ? (e.bytes[1] & 0x7Fu) : 0u;
  if (q.size() >= 6 && q[1] != 0x08) {
    const unsigned start = static_cast<unsigned>(q[2] << 8 | q[3]);
    // FC05 and FC06 carry a value where the others carry a count: one address.
    const unsigned count =
        q[1] == 0x05 || q[1] == 0x06 ? 1u : static_cast<unsigned>(q[4] << 8 | q[5]);
    if (e.kind != SniffKind::Reply || !e.query.empty())
      s.addresses = std::pair{start, start + (count ? count : 1) - 1};
  }
  return s;
}

unsigned parse_number(const std::string& term, const std::string& text, int base) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used, base);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || v > 0xFFFF)
    throw UsageError(fmt::format("--filter: '{}' in '{}' is not a number{}", text, term,
                                 base == 16 ? " (hex address, e.g. 9000)" : ""));
  return static_cast<unsigned>(v);
}

std::pair<unsigned, unsigned> parse_range(const std::string& term, const std::string& text,
                                          int base) {
  const auto dash = text.find('-');
  if (dash == std::string::npos) {
    const unsigned v = parse_number(term, text, base);
    return {v, v};
  }
  const unsigned lo = parse_number(term, text.substr(0, dash), base);
  const unsigned hi = parse_number(term, text.substr(dash + 1), base);
  if (lo > hi)
    throw UsageError(fmt::format("--filter: range '{}' in '{}' runs backwards", text, term));
  return {lo, hi};
}

bool in_any(const std::vector<std::pair<unsigned, unsigned>>& ranges, unsigned v) {
  if (ranges.empty()) return true;
  for (const auto& [lo, hi] : ranges)
    if (v >= lo && v <= hi) return true;
  return false;
}

}  // namespace

std::string flag_words(const SniffEvent& e) {
  std::string out;
  const auto add = [&](modbus::SniffFlag f, const char* word) {
    if (!e.has(f)) return;
    if (!out.empty()) out += ", ";
    out += word;
  };
  add(modbus::kSniffShortSilence, "short silence: the master did not keep Ts");
  add(modbus::kSniffLate, "late: the controller answered after Tx");
  add(modbus::kSniffUnsolicited, "a reply nobody asked for");
  add(modbus::kSniffSecondMaster, "a second master? this query came within the previous one's Tx");
  add(modbus::kSniffBroadcast, "broadcast");
  add(modbus::kSniffUnknownFunction, "unknown function code");
  return out;
}

SniffFilter SniffFilter::parse(const std::string& text) {
  SniffFilter f;
  std::string normalised = text;
  for (char& c : normalised)
    if (c == ';') c = ' ';
  std::size_t pos = 0;
  while (pos < normalised.size()) {
    const std::size_t end = std::min(normalised.find(' ', pos), normalised.size());
    const std::string term = normalised.substr(pos, end - pos);
    pos = end + 1;
    if (term.empty()) continue;
    const auto eq = term.find('=');
    if (eq == std::string::npos)
      throw UsageError(fmt::format("--filter: '{}' is not KEY=VALUE (id=, fn= or addr=)", term));
    const std::string key = term.substr(0, eq);
    const std::string value = term.substr(eq + 1);
    if (key == "addr") {
      f.addresses_ = parse_range(term, value, 16);
      continue;
    }
    if (key != "id" && key != "fn")
      throw UsageError(
          fmt::format("--filter: unknown key '{}' in '{}' (id=, fn= or addr=)", key, term));
    std::size_t p = 0;
    while (p <= value.size()) {
      const std::size_t comma = std::min(value.find(',', p), value.size());
      (key == "id" ? f.ids_ : f.functions_)
          .push_back(parse_range(term, value.substr(p, comma - p), 0));
      p = comma + 1;
    }
  }
  return f;
}

bool SniffFilter::passes(const SniffEvent& e) const {
  if (e.kind == SniffKind::Noise) return true;
  const Subject s = subject_of(e);
  if (!in_any(ids_, s.id) || !in_any(functions_, s.function)) return false;
  if (addresses_) {
    if (!s.addresses) return false;
    return s.addresses->first <= addresses_->second && addresses_->first <= s.addresses->second;
  }
  return true;
}

SniffPrinter::SniffPrinter(bool json, TimePoint origin, const modbus::LineTiming& timing)
    : json_(json),
      colour_(!json && ::isatty(STDOUT_FILENO) == 1),
      origin_(origin),
      timing_(timing) {}

void SniffPrinter::notice(const std::string& text) {
  fmt::print(stderr, "lec sniff: {}\n", text);
  std::fflush(stderr);
}

void SniffPrinter::event(const SniffEvent& e) {
  const std::string text = explain(e);
  const std::string flags = flag_words(e);
  if (json_) {
    nlohmann::json j = {{"t_us", us(e.first_byte - origin_)},
                        {"end_us", us(e.last_byte - origin_)},
                        {"dir", kind_name(e.kind)},
                        {"hex", modbus::to_hex(e.bytes)},
                        {"explanation", text}};
    if (e.query_number) j["query_number"] = e.query_number;
    if (e.silence) j["silence_ms"] = ms(*e.silence);
    if (e.kind == SniffKind::Query) j["ts_ms"] = ms(e.limit);
    if (e.response) j["response_ms"] = ms(*e.response);
    if (e.kind == SniffKind::Reply && !e.query.empty()) j["tx_ms"] = ms(e.limit);
    nlohmann::json f = nlohmann::json::array();
    for (const auto& [flag, name] : {std::pair{modbus::kSniffShortSilence, "short_silence"},
                                     {modbus::kSniffLate, "late"},
                                     {modbus::kSniffUnsolicited, "unsolicited"},
                                     {modbus::kSniffSecondMaster, "second_master"},
                                     {modbus::kSniffBadCrc, "bad_crc"},
                                     {modbus::kSniffBroadcast, "broadcast"},
                                     {modbus::kSniffUnknownFunction, "unknown_function"}}) {
      if (e.has(flag)) f.push_back(name);
    }
    j["flags"] = f;
    fmt::print("{}\n", dump_json(j));
    dirty_ = true;
    return;
  }
  static constexpr const char* kArrow[] = {"->", "<-", "~~", "!!"};
  std::string timing;
  if (e.silence)
    timing = fmt::format("  [silence {:.2f} ms, Ts {:.2f}]", ms(*e.silence), ms(e.limit));
  if (e.response) timing = fmt::format("  [{:.2f} ms, Tx {:.2f}]", ms(*e.response), ms(e.limit));
  const std::string number = e.query_number ? fmt::format("#{:<5}", e.query_number) : "      ";
  std::string line =
      fmt::format("{:12.6f} {} {} {}  | {}{}", ms(e.first_byte - origin_) / 1000.0,
                  kArrow[static_cast<int>(e.kind)], number, modbus::to_hex(e.bytes), text, timing);
  if (colour_) {
    const fmt::terminal_color c = e.kind == SniffKind::Query   ? fmt::terminal_color::cyan
                                  : e.kind == SniffKind::Reply ? fmt::terminal_color::green
                                                               : fmt::terminal_color::yellow;
    fmt::print("{}", fmt::styled(line, fmt::fg(c)));
    if (!flags.empty())
      fmt::print("{}", fmt::styled("  !! " + flags, fmt::fg(fmt::terminal_color::red)));
  } else {
    fmt::print("{}{}", line, flags.empty() ? "" : "  !! " + flags);
  }
  fmt::print("\n");
  dirty_ = true;
}

void SniffPrinter::flush() {
  std::fflush(stdout);
  dirty_ = false;
}

void SniffPrinter::flush_if_due(TimePoint now) {
  if (dirty_ && now - last_flush_ >= flush_within()) {
    flush();
    last_flush_ = now;
  }
}

void SniffPrinter::stats(const modbus::SniffStats& s, const modbus::SnifferOptions& options) {
  flush();
  if (json_) {
    nlohmann::json ids = nlohmann::json::object();
    for (const auto& [id, v] : s.ids) {
      ids[std::to_string(id)] = {{"queries", v.queries},
                                 {"exchanges", v.exchanges},
                                 {"exceptions", v.exceptions},
                                 {"timeouts", v.timeouts},
                                 {"crc_errors", v.crc_errors},
                                 {"late", v.late},
                                 {"unsolicited", v.unsolicited},
                                 {"response_p50_ms", ms(modbus::response_percentile(v, 0.5))},
                                 {"response_p99_ms", ms(modbus::response_percentile(v, 0.99))}};
    }
    nlohmann::json j = {{"stats",
                         {{"frames", s.frames},
                          {"noise_bursts", s.noise_bursts},
                          {"noise_bytes", s.noise_bytes},
                          {"short_silences", s.short_silences},
                          {"second_master", s.second_master},
                          {"untimed", s.untimed},
                          {"unknown_functions", s.unknown_functions},
                          {"lumpy", s.lumpy},
                          {"ids", ids}}}};
    fmt::print("{}\n", dump_json(j));
    std::fflush(stdout);
    return;
  }
  fmt::print(
      "statistics: {} frames, {} noise bursts ({} bytes), {} queries without Ts, {} over "
      "another master's transaction{}\n",
      s.frames, s.noise_bursts, s.noise_bytes, s.short_silences, s.second_master,
      s.unknown_functions ? fmt::format(", {} of an unknown function code", s.unknown_functions)
                          : "");
  if (s.lumpy)
    fmt::print(
        "timing: partly not judged, the adapter delivered frames in lumps (set its latency "
        "timer to 1 ms)\n");
  if (!options.check_timing) fmt::print("timing: not judged (--no-timing)\n");
  fmt::print("{:>4} {:>9} {:>9} {:>10} {:>8} {:>10} {:>6} {:>11} {:>8} {:>8}\n", "ID", "queries",
             "exchanges", "exceptions", "timeouts", "CRC errors", "late", "unsolicited", "p50 ms",
             "p99 ms");
  for (const auto& [id, v] : s.ids) {
    fmt::print("{:>4} {:>9} {:>9} {:>10} {:>8} {:>10} {:>6} {:>11} {:>8.2f} {:>8.2f}\n", id,
               v.queries, v.exchanges, v.exceptions, v.timeouts, v.crc_errors, v.late,
               v.unsolicited, ms(modbus::response_percentile(v, 0.5)),
               ms(modbus::response_percentile(v, 0.99)));
  }
  std::fflush(stdout);
  (void)timing_;
}

}  // namespace lec6::cli
