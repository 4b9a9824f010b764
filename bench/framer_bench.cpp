// The client's framer on a byte stream: how fast a reply is recognised as it
// arrives whole (a pty, a USB adapter's 1 ms batch), byte by byte (a UART
// interrupt per character), and after line noise it must resynchronise past.

#include <benchmark/benchmark.h>

#include <cstdint>
#include <span>
#include <vector>

#include "lec6/modbus/framer.hpp"
#include "lec6/modbus/pdu.hpp"

namespace {

using namespace lec6::modbus;

const Request kReadState = ReadRegistersRequest{0x9000, 7};

Bytes reply() {
  return encode_response({1, ReadRegistersResponse{{0, 15000, 100, 35, 0, 39000, 0}}});
}

// Feeds `stream` in chunks of `chunk` bytes; one iteration = one transaction.
void run(benchmark::State& state, const Bytes& stream, std::size_t chunk) {
  ClientFramer framer;
  for (auto _ : state) {
    framer.expect(1, kReadState);
    auto status = ClientFramer::Status::Incomplete;
    for (std::size_t at = 0; at < stream.size() && status == ClientFramer::Status::Incomplete;
         at += chunk) {
      const std::size_t n = std::min(chunk, stream.size() - at);
      status = framer.feed(std::span(stream).subspan(at, n));
    }
    if (status != ClientFramer::Status::Complete) state.SkipWithError("reply not recognised");
    benchmark::DoNotOptimize(framer.frame().data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * stream.size()));
}

void BM_ClientFramer_WholeReply(benchmark::State& s) {
  run(s, reply(), 64);
}
void BM_ClientFramer_ByteByByte(benchmark::State& s) {
  run(s, reply(), 1);
}

// Four stray bytes (a reply's tail from another ID, noise) before the reply.
void BM_ClientFramer_Resync4(benchmark::State& s) {
  Bytes stream{0x01, 0x03, 0x55, 0xAA};
  const Bytes r = reply();
  stream.insert(stream.end(), r.begin(), r.end());
  run(s, stream, 64);
}

// A 16-controller poll cycle on one stream: the framer's steady state.
void BM_ClientFramer_Stream(benchmark::State& state) {
  const Bytes r = reply();
  const Bytes flags =
      encode_response({1, ReadBitsResponse{FunctionCode::ReadInputs, {0x00, 0x0E}}});
  const Request read_flags = ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16};
  ClientFramer framer;
  for (auto _ : state) {
    framer.expect(1, kReadState);
    benchmark::DoNotOptimize(framer.feed(r));
    framer.expect(1, read_flags);
    benchmark::DoNotOptimize(framer.feed(flags));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 2));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * (r.size() + flags.size())));
}

BENCHMARK(BM_ClientFramer_WholeReply);
BENCHMARK(BM_ClientFramer_ByteByByte);
BENCHMARK(BM_ClientFramer_Resync4);
BENCHMARK(BM_ClientFramer_Stream);

}  // namespace
