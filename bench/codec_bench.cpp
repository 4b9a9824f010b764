// Request encoding and reply decoding: the client's per-transaction codec work
// for the two polling reads (D9000x7 state, X40x16 flags) and the largest
// write the client sends in normal use (FC10 D9102x16, a direct-operation record).

#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>

#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/pdu.hpp"

namespace {

using namespace lec6::modbus;

const RequestFrame kReadState{1, ReadRegistersRequest{0x9000, 7}};
const RequestFrame kReadFlags{1, ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16}};

RequestFrame write_direct_frame() {
  std::array<uint16_t, 16> regs{1, 100, 0, 39000, 1000, 1000, 0, 0, 20, 100, 0, 0, 0, 0, 0, 50};
  return {1, WriteRegistersRequest::of(0x9102, regs)};
}

void encode(benchmark::State& state, const RequestFrame& frame) {
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto adu = encode_request(frame);
    benchmark::DoNotOptimize(adu);
    bytes += adu->size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<int64_t>(bytes));
}

void BM_EncodeRequest_ReadState(benchmark::State& s) {
  encode(s, kReadState);
}
void BM_EncodeRequest_ReadFlags(benchmark::State& s) {
  encode(s, kReadFlags);
}
void BM_EncodeRequest_WriteDirect16(benchmark::State& s) {
  encode(s, write_direct_frame());
}

// The replies the twin sends to the two polling reads.
Bytes state_reply() {
  return encode_response({1, ReadRegistersResponse{{0, 15000, 100, 35, 0, 39000, 0}}});
}
Bytes flags_reply() {
  return encode_response({1, ReadBitsResponse{FunctionCode::ReadInputs, {0x00, 0x0E}}});
}

void decode(benchmark::State& state, const Bytes& adu) {
  for (auto _ : state) {
    auto r = decode_response(adu);
    benchmark::DoNotOptimize(r);
    if (!r) state.SkipWithError("reply does not decode");
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * adu.size()));
}

void BM_DecodeResponse_ReadState(benchmark::State& s) {
  decode(s, state_reply());
}
void BM_DecodeResponse_ReadFlags(benchmark::State& s) {
  decode(s, flags_reply());
}

// The twin's side of the codec: decode the query.
void BM_DecodeRequest_ReadState(benchmark::State& state) {
  const Bytes adu = *encode_request(kReadState);
  for (auto _ : state) {
    auto r = decode_request(adu);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}

BENCHMARK(BM_EncodeRequest_ReadState);
BENCHMARK(BM_EncodeRequest_ReadFlags);
BENCHMARK(BM_EncodeRequest_WriteDirect16);
BENCHMARK(BM_DecodeResponse_ReadState);
BENCHMARK(BM_DecodeResponse_ReadFlags);
BENCHMARK(BM_DecodeRequest_ReadState);

}  // namespace
