// libFuzzer entry point. Request decoding, check_request, explain and the controller's framer:
// [ctl][line bytes].
#include <cstddef>
#include <cstdint>

#include "harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::request_one(data, size);
  return 0;
}
