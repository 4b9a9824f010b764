// libFuzzer entry point. What a client may send to the Modbus TCP port: the
// MBAP framer (whole and in chunks) and the gateway's rules: [ctl][bytes].
#include <cstddef>
#include <cstdint>

#include "harness_mbap.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::mbap_one(data, size);
  return 0;
}
