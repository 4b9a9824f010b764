#include "line/telemetry_cache.hpp"

namespace lec6::serve {
namespace {

using modbus::FunctionCode;

struct Range {
  Block block;
  FunctionCode function;
  uint16_t first;
  uint16_t count;
};

// The three blocks as (function, first address, count).
constexpr std::array<Range, kBlocks> kRanges{{
    {Block::Flags, FunctionCode::ReadInputs, lec::kStatusInputs, lec::kStatusInputCount},
    {Block::State, FunctionCode::ReadRegisters, lec::kStateData, lec::kStateDataRegisters},
    {Block::Controls, FunctionCode::ReadCoils, 0x10, 33},  // Y10–Y30 (field practice)
    {Block::Alarms, FunctionCode::ReadRegisters, lec::kAlarmHistory, lec::kAlarmHistoryRegisters},
}};

struct Read {
  FunctionCode function;
  uint16_t start;
  uint16_t count;
};

std::optional<Read> read_of(const modbus::Request& r) {
  if (const auto* b = std::get_if<modbus::ReadBitsRequest>(&r)) {
    return Read{b->function, b->start, b->count};
  }
  if (const auto* q = std::get_if<modbus::ReadRegistersRequest>(&r)) {
    return Read{FunctionCode::ReadRegisters, q->start, q->count};
  }
  return std::nullopt;
}

// The block containing the whole read, if any.
const Range* containing(const Read& r) {
  for (const Range& range : kRanges) {
    if (range.function == r.function && r.start >= range.first &&
        r.start + r.count <= range.first + range.count) {
      return &range;
    }
  }
  return nullptr;
}

std::vector<uint16_t> values_of(const modbus::Response& response, uint16_t count) {
  if (const auto* regs = std::get_if<modbus::ReadRegistersResponse>(&response)) {
    return regs->values;
  }
  std::vector<uint16_t> bits;
  if (const auto* b = std::get_if<modbus::ReadBitsResponse>(&response)) {
    for (uint16_t i = 0; i < count; ++i) bits.push_back(b->bit(i) ? 1 : 0);
  }
  return bits;
}

modbus::Response reply_of(const Read& r, const Range& range, const CachedBlock& block) {
  const auto from = block.values.begin() + (r.start - range.first);
  if (r.function == FunctionCode::ReadRegisters) {
    return modbus::ReadRegistersResponse{std::vector<uint16_t>(from, from + r.count)};
  }
  modbus::Bytes packed((r.count + 7u) / 8u, 0);
  for (uint16_t i = 0; i < r.count; ++i) {
    if (from[i]) packed[i / 8] = static_cast<uint8_t>(packed[i / 8] | (1U << (i % 8)));
  }
  return modbus::ReadBitsResponse{r.function, std::move(packed)};
}

}  // namespace

modbus::Request block_request(Block b) {
  const Range& r = kRanges[static_cast<std::size_t>(b)];
  if (r.function == FunctionCode::ReadRegisters) {
    return modbus::ReadRegistersRequest{r.first, r.count};
  }
  return modbus::ReadBitsRequest{r.function, r.first, r.count};
}

std::optional<Block> TelemetryCache::update(uint8_t id, const modbus::Request& request,
                                            const modbus::Response& response, TimePoint started) {
  const auto read = read_of(request);
  if (!read) return std::nullopt;
  const Range* range = containing(*read);
  if (!range || read->start != range->first || read->count != range->count) return std::nullopt;
  auto values = values_of(response, read->count);
  if (values.size() != range->count) return std::nullopt;  // an exception reply, say
  auto& slot = axes_[id].blocks[static_cast<std::size_t>(range->block)];
  slot = CachedBlock{std::move(values), started};
  return range->block;
}

void TelemetryCache::invalidate(uint8_t id, TimePoint at) {
  axes_[id].written = at;
}

void TelemetryCache::invalidate_all(TimePoint at) {
  for (auto& [id, axis] : axes_) axis.written = at;
}

const CachedBlock* TelemetryCache::usable(const Axis& a, Block b) const {
  const auto& slot = a.blocks[static_cast<std::size_t>(b)];
  if (!slot || slot->taken < a.written) return nullptr;
  return &*slot;
}

std::optional<TelemetryCache::Hit> TelemetryCache::lookup(uint8_t id,
                                                          const modbus::Request& request,
                                                          Duration max_age, TimePoint now,
                                                          TimePoint not_before) const {
  const auto read = read_of(request);
  const auto axis = axes_.find(id);
  if (!read || axis == axes_.end() || max_age <= Duration{}) return std::nullopt;
  const Range* range = containing(*read);
  if (!range) return std::nullopt;
  const CachedBlock* block = usable(axis->second, range->block);
  if (!block || now - block->taken > max_age || block->taken < not_before) return std::nullopt;
  return Hit{reply_of(*read, *range, *block), block->taken};
}

std::optional<Duration> TelemetryCache::age(uint8_t id, Block b, TimePoint now) const {
  const auto axis = axes_.find(id);
  if (axis == axes_.end()) return std::nullopt;
  const CachedBlock* block = usable(axis->second, b);
  if (!block) return std::nullopt;
  return now - block->taken;
}

AxisSnapshot TelemetryCache::snapshot(uint8_t id) const {
  AxisSnapshot s;
  const auto axis = axes_.find(id);
  if (axis == axes_.end()) return s;
  const auto& blocks = axis->second.blocks;
  if (const auto& f = blocks[static_cast<std::size_t>(Block::Flags)]) {
    lec::StatusFlags flags;
    for (std::size_t i = 0; i < f->values.size(); ++i) {
      flags.set(static_cast<lec::StatusFlags::Bit>(i), f->values[i] != 0);
    }
    const auto polarity = polarity_.find(id);
    s.flags = polarity == polarity_.end() ? flags : lec::normalise_alarm(flags, polarity->second);
    s.flags_at = f->taken;
  }
  if (const auto& st = blocks[static_cast<std::size_t>(Block::State)]) {
    s.state = lec::StateData::from_registers(st->values);
    s.state_at = st->taken;
  }
  if (const auto& c = blocks[static_cast<std::size_t>(Block::Controls)]) {
    lec::ControlFlags controls;
    for (unsigned i = 0; i < 16; ++i) {
      if (c->values[i]) controls.y10_1f = static_cast<uint16_t>(controls.y10_1f | (1U << i));
    }
    controls.serial_mode = c->values[32] != 0;
    s.controls = controls;
    s.controls_at = c->taken;
  }
  if (const auto& a = blocks[static_cast<std::size_t>(Block::Alarms)]) {
    s.alarms = lec::AlarmHistory::from_registers(a->values);
    s.alarms_at = a->taken;
  }
  return s;
}

}  // namespace lec6::serve
