#pragma once
// 32-bit values travel in two registers, high word first, two's complement
// (digest §4). These are the only places that split and join them.
//
// Thread safety: pure functions.

#include <cstdint>

namespace lec6::lec {

constexpr uint16_t high_word(int32_t v) noexcept {
  return static_cast<uint16_t>(static_cast<uint32_t>(v) >> 16);
}
constexpr uint16_t low_word(int32_t v) noexcept {
  return static_cast<uint16_t>(static_cast<uint32_t>(v) & 0xFFFF);
}
constexpr int32_t join_words(uint16_t high, uint16_t low) noexcept {
  return static_cast<int32_t>((static_cast<uint32_t>(high) << 16) | low);
}

static_assert(join_words(high_word(-15000), low_word(-15000)) == -15000);

}  // namespace lec6::lec
