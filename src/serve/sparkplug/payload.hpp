#pragma once
// Sparkplug B payloads (Eclipse Sparkplug 3.0, chapter 6) as plain C++ values,
// and their protobuf encoding (sparkplug_b.proto, Debian's libprotobuf-lite):
// nothing else in lec serve sees protobuf.
//
// Tests: SparkplugPayload.RoundTripsEveryTypeItWrites, and Eclipse Tahu's JS
// codec decoding every message of integration.sparkplug_host.
//
// Thread safety: pure functions and values.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "lec6/expected.hpp"

namespace lec6::serve::sparkplug {

// The specification's data types (the ones lec6 uses, and the ones a host
// may send in a command).
enum class DataType : uint32_t {
  Unknown = 0,
  Int8 = 1,
  Int16 = 2,
  Int32 = 3,
  Int64 = 4,
  UInt8 = 5,
  UInt16 = 6,
  UInt32 = 7,
  UInt64 = 8,
  Float = 9,
  Double = 10,
  Boolean = 11,
  String = 12,
  DateTime = 13,
  Text = 14,
};
std::string_view type_name(DataType t) noexcept;

// A metric's value: null, or as its data type holds it (integers signed or
// unsigned by the type, Float and Double as double, String and Text as text).
using Value = std::variant<std::monostate, bool, int64_t, uint64_t, double, std::string>;

struct Metric {
  std::optional<std::string> name;
  std::optional<uint64_t> alias;
  std::optional<uint64_t> timestamp_ms;
  std::optional<DataType> datatype;
  Value value;             // monostate: is_null (or no value at all in what was read)
  bool has_value = false;  // decoding: a value field was present
};

struct Payload {
  std::optional<uint64_t> timestamp_ms;
  std::optional<uint64_t> seq;
  std::vector<Metric> metrics;
};

// Encodes `p`; a metric's value is written in the field its datatype names
// (int_value, long_value, ...), is_null when it holds none.
std::string encode(const Payload& p);

// Decodes a payload. Values are read by the metric's datatype when it has
// one; without one, as the field present holds it. A payload that is not
// Sparkplug protobuf: the reason.
Expected<Payload, std::string> decode(std::string_view bytes);
// The metrics that parse, each on its own: a metric that is not well-formed,
// or a payload cut short, costs only itself (what follows a broken length
// is lost). For finding a stop among siblings that decode() would refuse
// whole (session.hpp: a stop never falls with anything else).
std::vector<Metric> decode_metrics_leniently(std::string_view bytes);
// The same walk, metric by metric, until `visit` returns false (a stop found).
void visit_metrics_leniently(std::string_view bytes, const std::function<bool(Metric&&)>& visit);

}  // namespace lec6::serve::sparkplug
