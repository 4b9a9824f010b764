// libFuzzer entry point. Reply decoding and the client's framer/transaction: [ctl][request
// ADU][reply bytes].
#include <cstddef>
#include <cstdint>

#include "harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::reply_one(data, size);
  return 0;
}
