// libFuzzer entry point. The sniffer (modbus::Sniffer) and the capture file
// reader: [ctl][bytes heard on the line] (fuzz/harness_sniff.hpp).
#include <cstddef>
#include <cstdint>

#include "harness_sniff.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::sniff_one(data, size);
  return 0;
}
