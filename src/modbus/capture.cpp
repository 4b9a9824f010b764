// The capture format's codec (docs/capture-format.md).

#include "lec6/modbus/capture.hpp"

#include <fmt/format.h>

#include <ctime>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>

namespace lec6::modbus {
namespace {

using Json = nlohmann::json;

constexpr char kHexDigits[] = "0123456789abcdef";

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// A problem in one line; the parser adds the file, line and offset.
struct LineProblem {
  std::string text;
};

[[noreturn]] void fail(std::string text) { throw LineProblem{std::move(text)}; }

const Json* member(const Json& object, const char* key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

std::string text_member(const Json& object, const char* key, bool required) {
  const Json* v = member(object, key);
  if (!v) {
    if (required) fail(fmt::format("'{}' is missing", key));
    return {};
  }
  if (!v->is_string()) fail(fmt::format("'{}' must be a string, not {}", key, v->dump()));
  return v->get<std::string>();
}

int64_t integer_member(const Json& object, const char* key, int64_t min, int64_t max) {
  const Json* v = member(object, key);
  if (!v) fail(fmt::format("'{}' is missing", key));
  if (!v->is_number_integer())
    fail(fmt::format("'{}' must be a whole number, not {}", key, v->dump()));
  if (v->is_number_unsigned() && v->get<uint64_t>() > static_cast<uint64_t>(max))
    fail(fmt::format("'{}' is {}, outside {}..{}", key, v->dump(), min, max));
  const int64_t n = v->get<int64_t>();
  if (n < min || n > max) fail(fmt::format("'{}' is {}, outside {}..{}", key, n, min, max));
  return n;
}

CaptureLine parse_line_settings(const Json& header) {
  CaptureLine line;
  const Json* v = member(header, "line");
  if (!v) return line;
  if (!v->is_object()) fail(fmt::format("'line' must be an object, not {}", v->dump()));
  if (member(*v, "baud"))
    line.baud = static_cast<uint32_t>(integer_member(*v, "baud", 1, 100'000'000));
  if (member(*v, "parity")) {
    const std::string p = text_member(*v, "parity", true);
    if (p != "E" && p != "O" && p != "N")
      fail(fmt::format("'line.parity' is \"{}\"; it must be \"E\", \"O\" or \"N\"", p));
    line.parity = p[0];
  }
  if (member(*v, "data_bits"))
    line.data_bits = static_cast<uint8_t>(integer_member(*v, "data_bits", 5, 8));
  if (member(*v, "stop_bits"))
    line.stop_bits = static_cast<uint8_t>(integer_member(*v, "stop_bits", 1, 2));
  return line;
}

CaptureHeader parse_header(const Json& j) {
  if (!j.is_object()) fail("the first line is not a lec6 capture header (not a JSON object)");
  const Json* format = member(j, "format");
  if (!format) fail("not a lec6 capture: the first line has no 'format'");
  if (!format->is_string() || format->get<std::string>() != kCaptureFormat)
    fail(fmt::format("not a lec6 capture: 'format' is {}, expected \"{}\"", format->dump(),
                     kCaptureFormat));
  const Json* version = member(j, "version");
  if (!version) fail("the header has no 'version'");
  if (!version->is_number_integer())
    fail(fmt::format("'version' must be a whole number, not {}", version->dump()));
  const int64_t v = version->get<int64_t>();
  if (version->is_number_unsigned() ? version->get<uint64_t>() > kCaptureVersion
                                    : v > kCaptureVersion)
    fail(fmt::format("version {} is newer than this lec reads (version {}); use a newer lec",
                     version->dump(), kCaptureVersion));
  if (v < 1) fail(fmt::format("'version' is {}; versions start at 1", v));
  CaptureHeader h;
  h.version = static_cast<int>(v);
  h.source = text_member(j, "source", false);
  h.started_utc = text_member(j, "started_utc", false);
  h.line = parse_line_settings(j);
  h.port = text_member(j, "port", false);
  h.tool = text_member(j, "tool", false);
  return h;
}

CaptureDir parse_dir(const std::string& name) {
  for (const CaptureDir d :
       {CaptureDir::Query, CaptureDir::Reply, CaptureDir::Noise, CaptureDir::Unknown}) {
    if (capture_dir_name(d) == name) return d;
  }
  fail(fmt::format("'dir' is \"{}\"; it must be \"query\", \"reply\", \"noise\" or \"unknown\"",
                   name));
}

Bytes parse_hex(const std::string& hex) {
  if (hex.empty()) fail("'hex' is empty (a record carries at least one byte)");
  if (hex.size() % 2 != 0) fail("'hex' has an odd number of digits");
  Bytes out(hex.size() / 2);
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    const int hi = hex_value(hex[i]);
    const int lo = hex_value(hex[i + 1]);
    if (hi < 0 || lo < 0) {
      const std::size_t at = hi < 0 ? i : i + 1;
      fail(fmt::format("'hex' has '{}' at digit {}, not a hex digit", hex[at], at + 1));
    }
    out[i / 2] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return out;
}

constexpr int64_t kMaxMicroseconds = std::numeric_limits<int64_t>::max() / 2;

CaptureRecord parse_record(const Json& j) {
  if (!j.is_object()) fail(fmt::format("a record must be a JSON object, not {}", j.dump()));
  CaptureRecord r;
  r.t_us = integer_member(j, "t_us", 0, kMaxMicroseconds);
  r.end_us = integer_member(j, "end_us", 0, kMaxMicroseconds);
  if (r.end_us < r.t_us)
    fail(fmt::format("'end_us' ({}) is before 't_us' ({})", r.end_us, r.t_us));
  r.dir = parse_dir(text_member(j, "dir", true));
  r.bytes = parse_hex(text_member(j, "hex", true));
  r.note = text_member(j, "note", false);
  return r;
}

bool is_blank(std::string_view line) {
  return line.find_first_not_of(" \t\r") == std::string_view::npos;
}

}  // namespace

CaptureError::CaptureError(std::string_view file_name, std::size_t line, std::size_t offset,
                           std::string_view problem)
    : InvalidArgument(fmt::format("{}, line {} (byte {}): {}", file_name, line, offset, problem)),
      line_(line),
      offset_(offset) {}

std::string_view capture_dir_name(CaptureDir d) noexcept {
  switch (d) {
    case CaptureDir::Query: return "query";
    case CaptureDir::Reply: return "reply";
    case CaptureDir::Noise: return "noise";
    case CaptureDir::Unknown: return "unknown";
  }
  return "unknown";
}

std::string encode_capture_header(const CaptureHeader& h) {
  nlohmann::ordered_json j;
  j["format"] = kCaptureFormat;
  j["version"] = h.version;
  j["source"] = h.source;
  j["started_utc"] = h.started_utc;
  j["line"] = {{"baud", h.line.baud},
               {"parity", std::string(1, h.line.parity)},
               {"data_bits", h.line.data_bits},
               {"stop_bits", h.line.stop_bits}};
  j["port"] = h.port;
  j["tool"] = h.tool;
  std::string out = j.dump(-1, ' ', false, Json::error_handler_t::replace);
  out.push_back('\n');
  return out;
}

// Formatted by hand: this runs once per frame while recording.
std::string encode_capture_record(const CaptureRecord& r) {
  std::string out;
  out.reserve(64 + r.bytes.size() * 2 + r.note.size());
  out += "{\"t_us\":";
  fmt::format_to(std::back_inserter(out), "{}", r.t_us);
  out += ",\"end_us\":";
  fmt::format_to(std::back_inserter(out), "{}", r.end_us);
  out += ",\"dir\":\"";
  out += capture_dir_name(r.dir);
  out += "\",\"hex\":\"";
  for (const uint8_t b : r.bytes) {
    out.push_back(kHexDigits[b >> 4]);
    out.push_back(kHexDigits[b & 0x0F]);
  }
  out.push_back('"');
  if (!r.note.empty()) {
    out += ",\"note\":";
    out += Json(r.note).dump(-1, ' ', false, Json::error_handler_t::replace);
  }
  out += "}\n";
  return out;
}

Capture parse_capture(std::string_view text, std::string_view file_name) {
  if (text.empty()) throw CaptureError(file_name, 1, 0, "the file is empty (no capture header)");
  Capture capture;
  bool have_header = false;
  std::size_t offset = 0;
  std::size_t line_number = 0;
  int64_t previous_t_us = 0;
  while (offset < text.size()) {
    ++line_number;
    const std::size_t newline = text.find('\n', offset);
    const bool cut = newline == std::string_view::npos;
    const std::size_t end = cut ? text.size() : newline;
    const std::string_view line = text.substr(offset, end - offset);
    try {
      if (!is_blank(line)) {
        Json j;
        try {
          j = Json::parse(line);
        } catch (const Json::parse_error& e) {
          if (cut)
            fail("the file ends in the middle of this line (cut short? the last line has no end)");
          const std::size_t column = e.byte == 0 ? 1 : e.byte;
          fail(fmt::format("not valid JSON at column {}", column));
        }
        if (!have_header) {
          capture.header = parse_header(j);
          have_header = true;
        } else {
          CaptureRecord r = parse_record(j);
          if (r.t_us < previous_t_us)
            fail(fmt::format("records out of time order: 't_us' {} is before the previous "
                             "record's {}",
                             r.t_us, previous_t_us));
          previous_t_us = r.t_us;
          capture.records.push_back(std::move(r));
        }
      }
    } catch (const LineProblem& p) {
      throw CaptureError(file_name, line_number, offset, p.text);
    } catch (const Json::exception& e) {  // defensive: a conversion we did not foresee
      throw CaptureError(file_name, line_number, offset, e.what());
    }
    offset = cut ? text.size() : newline + 1;
  }
  if (!have_header) throw CaptureError(file_name, 1, 0, "the file has no capture header");
  return capture;
}

std::string format_capture_utc(std::chrono::system_clock::time_point t) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch());
  auto seconds = us.count() / 1'000'000;
  auto micros = us.count() % 1'000'000;
  if (micros < 0) {
    micros += 1'000'000;
    --seconds;
  }
  const std::time_t tt = static_cast<std::time_t>(seconds);
  std::tm tm{};
  ::gmtime_r(&tt, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:06}Z", tm.tm_year + 1900,
                     tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, micros);
}

}  // namespace lec6::modbus
