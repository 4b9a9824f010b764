// libFuzzer entry point. The twin's whole request handling: sequences of frames on one model (see
// harness.hpp).
#include <cstddef>
#include <cstdint>

#include "harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::twin_one(data, size);
  return 0;
}
