// What `lec --record` adds to a transaction (issue 24): the same read-state
// transaction (D9000×7) through RtuMaster on the in-process twin (virtual
// clock: the wire costs no wall time, so only the software is measured),
// without and with the recording link writing a capture file. The difference
// is the recording's cost per transaction, to set beside the transaction's
// 16.9 ms on a 38400-baud line (BENCHMARKS.md, "Recording").

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "lec6/client/rtu_master.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/recording_link.hpp"
#include "lec6/twin/line_recorder.hpp"
#include "lec6/twin/sim_link.hpp"

namespace {

using namespace lec6;

void read_state(benchmark::State& state, bool record) {
  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  sim::Bus bus;
  bus.add(1, {}, clock.now());
  twin::SimLink link(bus, clock);
  const std::string path =
      (std::filesystem::temp_directory_path() / "lec6_record_bench.jsonl").string();
  std::unique_ptr<twin::LineRecorder> recorder;
  std::unique_ptr<transport::RecordingLink> recording;
  client::Link* l = &link;
  if (record) {
    recorder = std::make_unique<twin::LineRecorder>(path, "bench", 38400, "sim", clock);
    recording = std::make_unique<transport::RecordingLink>(link, recorder->tap());
    l = recording.get();
  }
  client::RtuMaster master(*l);
  const modbus::RequestFrame q{1, modbus::ReadRegistersRequest{0x9000, 7}};
  for (auto _ : state) benchmark::DoNotOptimize(master.exchange(q));
  state.counters["tx/s"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                              benchmark::Counter::kIsRate);
  recording.reset();
  recorder.reset();
  std::filesystem::remove(path);
}

void BM_Transaction_ReadState(benchmark::State& s) {
  read_state(s, false);
}
void BM_Transaction_ReadState_Recorded(benchmark::State& s) {
  read_state(s, true);
}
BENCHMARK(BM_Transaction_ReadState);
BENCHMARK(BM_Transaction_ReadState_Recorded);

}  // namespace
