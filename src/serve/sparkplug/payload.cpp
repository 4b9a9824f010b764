#include "sparkplug/payload.hpp"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/wire_format_lite.h>

#include "sparkplug_b.pb.h"

namespace lec6::serve::sparkplug {
namespace {

using Pb = org::eclipse::tahu::protobuf::Payload;

bool is_small_int(DataType t) {
  return t == DataType::Int8 || t == DataType::Int16 || t == DataType::Int32 ||
         t == DataType::UInt8 || t == DataType::UInt16;
}
bool is_signed(DataType t) {
  return t == DataType::Int8 || t == DataType::Int16 || t == DataType::Int32 ||
         t == DataType::Int64;
}

int64_t value_as_int(const Value& v) {
  if (const auto* i = std::get_if<int64_t>(&v)) return *i;
  if (const auto* u = std::get_if<uint64_t>(&v)) return static_cast<int64_t>(*u);
  if (const auto* b = std::get_if<bool>(&v)) return *b ? 1 : 0;
  if (const auto* d = std::get_if<double>(&v)) return static_cast<int64_t>(*d);
  return 0;
}

void write_value(Pb::Metric& m, DataType t, const Value& v) {
  if (std::holds_alternative<std::monostate>(v)) {
    m.set_is_null(true);
    return;
  }
  switch (t) {
    case DataType::Boolean:
      m.set_boolean_value(std::holds_alternative<bool>(v) ? std::get<bool>(v)
                                                          : value_as_int(v) != 0);
      return;
    case DataType::Float:
      m.set_float_value(static_cast<float>(
          std::get_if<double>(&v) ? std::get<double>(v) : static_cast<double>(value_as_int(v))));
      return;
    case DataType::Double:
      m.set_double_value(std::get_if<double>(&v) ? std::get<double>(v)
                                                 : static_cast<double>(value_as_int(v)));
      return;
    case DataType::String:
    case DataType::Text:
      m.set_string_value(std::get_if<std::string>(&v) ? std::get<std::string>(v) : std::string());
      return;
    default:
      if (is_small_int(t)) {
        m.set_int_value(static_cast<uint32_t>(value_as_int(v)));
      } else {
        m.set_long_value(static_cast<uint64_t>(value_as_int(v)));
      }
  }
}

Value read_value(const Pb::Metric& m, std::optional<DataType> t) {
  using M = Pb::Metric;
  switch (m.value_case()) {
    case M::kIntValue:
      if (t && is_signed(*t)) return static_cast<int64_t>(static_cast<int32_t>(m.int_value()));
      return static_cast<int64_t>(m.int_value());
    case M::kLongValue:
      if (t && is_signed(*t)) return static_cast<int64_t>(m.long_value());
      return m.long_value();
    case M::kFloatValue:
      return static_cast<double>(m.float_value());
    case M::kDoubleValue:
      return m.double_value();
    case M::kBooleanValue:
      return m.boolean_value();
    case M::kStringValue:
      return m.string_value();
    case M::kBytesValue:
      return m.bytes_value();
    default:
      return std::monostate{};
  }
}

Metric from_pb(const Pb::Metric& m) {
  Metric out;
  if (m.has_name()) out.name = m.name();
  if (m.has_alias()) out.alias = m.alias();
  if (m.has_timestamp()) out.timestamp_ms = m.timestamp();
  if (m.has_datatype()) out.datatype = static_cast<DataType>(m.datatype());
  out.has_value = m.value_case() != Pb::Metric::VALUE_NOT_SET;
  out.value = m.is_null() ? Value{} : read_value(m, out.datatype);
  return out;
}

}  // namespace

std::string_view type_name(DataType t) noexcept {
  switch (t) {
    case DataType::Int8:
      return "Int8";
    case DataType::Int16:
      return "Int16";
    case DataType::Int32:
      return "Int32";
    case DataType::Int64:
      return "Int64";
    case DataType::UInt8:
      return "UInt8";
    case DataType::UInt16:
      return "UInt16";
    case DataType::UInt32:
      return "UInt32";
    case DataType::UInt64:
      return "UInt64";
    case DataType::Float:
      return "Float";
    case DataType::Double:
      return "Double";
    case DataType::Boolean:
      return "Boolean";
    case DataType::String:
      return "String";
    case DataType::DateTime:
      return "DateTime";
    case DataType::Text:
      return "Text";
    default:
      return "Unknown";
  }
}

std::string encode(const Payload& p) {
  Pb pb;
  if (p.timestamp_ms) pb.set_timestamp(*p.timestamp_ms);
  if (p.seq) pb.set_seq(*p.seq);
  for (const Metric& m : p.metrics) {
    auto* out = pb.add_metrics();
    if (m.name) out->set_name(*m.name);
    if (m.alias) out->set_alias(*m.alias);
    if (m.timestamp_ms) out->set_timestamp(*m.timestamp_ms);
    const DataType t = m.datatype.value_or(DataType::Unknown);
    if (m.datatype) out->set_datatype(static_cast<uint32_t>(t));
    write_value(*out, t, m.value);
  }
  return pb.SerializeAsString();
}

Expected<Payload, std::string> decode(std::string_view bytes) {
  Pb pb;
  if (!pb.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return unexpected(std::string("not a Sparkplug B payload (protobuf does not parse)"));
  }
  Payload p;
  if (pb.has_timestamp()) p.timestamp_ms = pb.timestamp();
  if (pb.has_seq()) p.seq = pb.seq();
  for (const auto& m : pb.metrics()) p.metrics.push_back(from_pb(m));
  return p;
}

// Our own walk of the outer message (protobuf's parser takes a message
// whole or not at all): field 2, length-delimited, is a metric.
void visit_metrics_leniently(std::string_view bytes, const std::function<bool(Metric&&)>& visit) {
  using google::protobuf::internal::WireFormatLite;
  google::protobuf::io::CodedInputStream in(reinterpret_cast<const uint8_t*>(bytes.data()),
                                            static_cast<int>(bytes.size()));
  for (uint32_t tag = in.ReadTag(); tag != 0; tag = in.ReadTag()) {
    if (WireFormatLite::GetTagFieldNumber(tag) == 2 &&
        WireFormatLite::GetTagWireType(tag) == WireFormatLite::WIRETYPE_LENGTH_DELIMITED) {
      uint32_t length = 0;
      std::string sub;
      if (!in.ReadVarint32(&length) || !in.ReadString(&sub, static_cast<int>(length))) break;
      Pb::Metric m;
      if (m.ParseFromString(sub) && !visit(from_pb(m))) return;
      continue;
    }
    if (!WireFormatLite::SkipField(&in, tag)) break;
  }
}

std::vector<Metric> decode_metrics_leniently(std::string_view bytes) {
  std::vector<Metric> out;
  visit_metrics_leniently(bytes, [&](Metric&& m) {
    out.push_back(std::move(m));
    return true;
  });
  return out;
}

}  // namespace lec6::serve::sparkplug
