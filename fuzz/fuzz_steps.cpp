// libFuzzer entry point. Step tables from CSV / JSON files: parse, validate, write and read back.
#include <cstddef>
#include <cstdint>

#include "harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::steps_one(data, size);
  return 0;
}
