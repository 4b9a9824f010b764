// The fuzz harnesses (fuzz/harness.hpp) in an ordinary test: every seed built
// from the golden frames, every input kept under tests/fuzz_regressions/<harness>/
// (past findings and hand-made hostile inputs), and a few frame-level bad
// inputs of docs/robustness.md, run through the same checks the fuzzers apply.
// Any compiler, no libFuzzer needed.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "../../fuzz/harness.hpp"
#include "../../fuzz/harness_sniff.hpp"
#include "../../fuzz/seeds.hpp"
#include "lec6/client/transaction.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::fuzz {
namespace {

namespace fs = std::filesystem;

const std::string kData = LEC6_TEST_DATA_DIR;
const fs::path kRegressions = fs::path(LEC6_TEST_DATA_DIR) / ".." / "fuzz_regressions";

void (*harness(const std::string& name))(const uint8_t*, std::size_t) {
  if (name == "reply") return reply_one;
  if (name == "request") return request_one;
  if (name == "twin") return twin_one;
  if (name == "sniff") return sniff_one;
  return steps_one;
}

// Property violations throw here instead of aborting.
struct ThrowOnFailure {
  ThrowOnFailure() {
    failure_handler() = [](const std::string& what) { throw std::runtime_error(what); };
  }
  ~ThrowOnFailure() { failure_handler() = nullptr; }
};

void run(const std::string& h, const modbus::Bytes& input, const std::string& label) {
  ThrowOnFailure guard;
  try {
    harness(h)(input.data(), input.size());
  } catch (const std::exception& e) {
    ADD_FAILURE() << h << " harness, input " << label << " (" << modbus::to_hex(input)
                  << "): " << e.what();
  }
}

class FuzzHarness : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzHarness, SeedsFromTheGoldenFramesPass) {
  const auto seeds =
      make_seeds(GetParam(), read_file(kData + "/manual-frames.tsv"), kData + "/steps");
  ASSERT_GE(seeds.size(), 5u);
  for (const auto& [name, bytes] : seeds) run(GetParam(), bytes, name);
}

// Every regular file in `dir`, name and content.
std::vector<std::pair<std::string, modbus::Bytes>> inputs_in(const fs::path& dir) {
  std::vector<std::pair<std::string, modbus::Bytes>> out;
  if (!fs::exists(dir)) return out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().filename().string().starts_with(".")) continue;
    const std::string text = read_file(entry.path().string());
    out.emplace_back(entry.path().filename().string(), modbus::Bytes(text.begin(), text.end()));
  }
  return out;
}

// Every kept input of the harness, in every build; a crash (sanitizers
// abort) or a property violation fails. The count run is printed (the CI log
// shows it: the Makefile runs this test verbosely). A harness without kept
// inputs passes only by running none and saying so.
TEST_P(FuzzHarness, KeptRegressionInputsPass) {
  ASSERT_TRUE(fs::is_regular_file(kRegressions / "README.md"))
      << "tests/fuzz_regressions/ not found at " << kRegressions;
  const auto inputs = inputs_in(kRegressions / GetParam());
  for (const auto& [name, bytes] : inputs) run(GetParam(), bytes, name);
  std::printf("fuzz regression replay: %zu kept input(s) of harness '%s' run%s\n", inputs.size(),
              GetParam().c_str(), inputs.empty() ? " (none kept)" : "");
  RecordProperty("inputs_run", static_cast<int>(inputs.size()));
}

// Mutations of every seed that the fuzzer would try first: each byte
// flipped, the input truncated at each length. Cheap, and it keeps the
// harnesses honest with any compiler.
TEST_P(FuzzHarness, EveryByteFlipAndTruncationOfTheSeedsPasses) {
  const auto seeds =
      make_seeds(GetParam(), read_file(kData + "/manual-frames.tsv"), kData + "/steps");
  std::size_t runs = 0;
  for (const auto& [name, bytes] : seeds) {
    if (bytes.size() > 400) continue;
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      modbus::Bytes m = bytes;
      m[i] ^= 0x41;
      run(GetParam(), m, name + " flip " + std::to_string(i));
      ++runs;
      if (bytes.size() > 100 && i % 3) continue;  // long seeds: every third cut
      run(GetParam(), modbus::Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(i)),
          name + " cut " + std::to_string(i));
      ++runs;
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(runs, 0u);
}

INSTANTIATE_TEST_SUITE_P(All, FuzzHarness, ::testing::Values("reply", "request", "twin", "steps", "sniff"),
                         [](const auto& info) { return info.param; });

// ---- frame-level bad inputs (docs/robustness.md) --------------------------------

modbus::Bytes hex(const char* text) {
  return *modbus::from_hex(text);
}

std::optional<sim::Reply> ask(sim::Bus& bus, const modbus::Bytes& q, TimePoint& t) {
  auto r = sim::transact(bus, q, t);
  t += std::chrono::milliseconds(100);
  return r;
}

TEST(BadFrames, TheTwinIgnoresBadCrcOtherIdsAndTruncatedFrames) {
  sim::Bus bus;
  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  bus.add(1, {}, t);
  const auto before = bus.find(1)->control();
  // Y30 ON with its CRC broken, to ID 2 (absent), cut short, with a byte too many.
  EXPECT_FALSE(ask(bus, hex("01 05 00 30 FF 00 8C 36"), t));
  EXPECT_FALSE(ask(bus, hex("02 05 00 30 FF 00 8C 06"), t));
  EXPECT_FALSE(ask(bus, hex("01 05 00 30 FF"), t));
  EXPECT_FALSE(ask(bus, hex("01 05 00 30 FF 00 8C 35 00"), t));
  EXPECT_EQ(bus.find(1)->control(), before) << "a bad frame changed the coils";
  EXPECT_EQ(bus.stats().replies, 0u);
  // The same frame intact is acted on.
  auto ok = ask(bus, hex("01 05 00 30 FF 00 8C 35"), t);
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->bytes, hex("01 05 00 30 FF 00 8C 35"));
  EXPECT_TRUE(bus.find(1)->control().serial_mode);
}

TEST(BadFrames, BroadcastReadsGetNoReplyAndChangeNothing) {
  sim::Bus bus;
  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  bus.add(1, {}, t);
  modbus::Bytes read_state = *modbus::encode_request({0, modbus::ReadRegistersRequest{0x9000, 7}});
  EXPECT_FALSE(ask(bus, read_state, t));
  modbus::Bytes serial_on =
      *modbus::encode_request({0, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}});
  EXPECT_FALSE(ask(bus, serial_on, t)) << "broadcast writes are executed without a reply";
  EXPECT_TRUE(bus.find(1)->control().serial_mode);
  EXPECT_EQ(bus.stats().broadcasts, 1u);
}

TEST(BadFrames, OutOfRangeRequestsGetTheDigestsExceptionCodes) {
  sim::Bus bus;
  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  bus.add(1, {}, t);
  const sim::Eeprom eeprom = bus.find(1)->eeprom();
  auto code = [&](const char* body) {
    modbus::Bytes q = hex(body);
    modbus::append_crc(q);
    auto r = ask(bus, q, t);
    if (!r) return -1;
    auto d = modbus::decode_response(r->bytes);
    if (!d) return -2;
    const auto* ex = std::get_if<modbus::ExceptionResponse>(&d->pdu);
    return ex ? static_cast<int>(ex->code) : 0;
  };
  EXPECT_EQ(code("01 04 90 00 00 01"), 1);              // FC04: no such function
  EXPECT_EQ(code("01 06 90 00 00 01"), 1);              // FC06: no single-register write
  EXPECT_EQ(code("01 03 20 00 00 01"), 2);              // start outside every area
  EXPECT_EQ(code("01 03 90 00 00 7E"), 3);              // 126 registers > 125
  EXPECT_EQ(code("01 03 90 00 00 00"), 3);              // count 0
  EXPECT_EQ(code("01 03 07 F0 00 20"), 3);              // runs past the step area
  EXPECT_EQ(code("01 05 00 30 12 34"), 3);              // FC05 value not FF00/0000
  EXPECT_EQ(code("01 08 00 01 00 00"), 2);              // echo test code not 0000
  EXPECT_EQ(code("01 10 90 00 00 01 02 00 01"), 2);     // write to read-only state
  EXPECT_EQ(code("01 05 00 19 FF 00"), 2);              // SVON in parallel mode
  EXPECT_EQ(code("01 10 04 00 00 02 03 00 01 00"), 3);  // byte count disagrees with the count
  EXPECT_EQ(bus.find(1)->eeprom(), eeprom) << "a refused request changed the EEPROM";
}

// Replies the controller could not have sent, with a good CRC: never accepted.
TEST(BadFrames, TheClientRefusesWellFormedRepliesThatDoNotFitTheRequest) {
  const modbus::RequestFrame read_state{1, modbus::ReadRegistersRequest{0x9000, 7}};
  auto outcome = [&](const char* body) {
    modbus::Bytes reply = hex(body);
    modbus::append_crc(reply);
    client::Transaction tx(read_state, client::TransactionTiming{});
    tx.sent(TimePoint{});
    tx.received(reply, TimePoint{} + std::chrono::milliseconds(10));
    if (tx.step() == client::Transaction::Step::Receive) tx.timed_out(tx.deadline());
    return tx.step() == client::Transaction::Step::Done
               ? std::string("accepted")
               : std::string(client::transport_error_name(tx.error_kind()));
  };
  EXPECT_EQ(outcome("01 83 07"), "framing");  // exception code 07
  EXPECT_EQ(outcome("01 03 0C 00 00 00 00 00 00 00 00 00 00 00 00"),
            "framing");  // 6 registers for 7
  EXPECT_EQ(outcome("02 03 0E 00 00 00 00 00 00 00 00 00 00 00 00 00 00"), "framing");  // ID 2
  EXPECT_EQ(outcome("01 04 0E 00 00 00 00 00 00 00 00 00 00 00 00 00 00"), "framing");  // FC04
  EXPECT_EQ(outcome("01 03 0E 00 00 00 00 00 00 00 00 00 00 00 00 00 00"), "accepted");
  EXPECT_EQ(outcome("01 83 02"),
            "accepted");  // an exception reply is a valid answer (ControllerException)
}

}  // namespace
}  // namespace lec6::fuzz
