// libFuzzer entry point. What a client may send to the HTTP port: the request
// reader (whole, byte by byte, in chunks), static paths, access rules, SSE
// framing: [ctl][bytes].
#include <cstddef>
#include <cstdint>

#include "harness_http.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lec6::fuzz::http_one(data, size);
  return 0;
}
