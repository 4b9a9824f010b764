#include "lec6/modbus/framer.hpp"

#include <gtest/gtest.h>

#include <random>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::modbus {
namespace {

const Bytes kReadPosition = *from_hex("01 03 90 00 00 02 E9 0B");
const Bytes kPositionReply = *from_hex("01 03 04 00 00 3A 98 E9 39");

ClientFramer framer_for_read_position() {
  ClientFramer f;
  f.expect(1, ReadRegistersRequest{0x9000, 2});
  return f;
}

TEST(ClientFramer, CompletesExactlyOnTheLastByte) {
  auto f = framer_for_read_position();
  for (std::size_t i = 0; i + 1 < kPositionReply.size(); ++i) {
    ASSERT_EQ(f.feed(std::span(&kPositionReply[i], 1)), ClientFramer::Status::Incomplete) << i;
    EXPECT_EQ(f.bytes_wanted(), kPositionReply.size() - i - 1);
  }
  ASSERT_EQ(f.feed(std::span(&kPositionReply.back(), 1)), ClientFramer::Status::Complete);
  EXPECT_EQ(to_hex(f.frame()), to_hex(kPositionReply));
  EXPECT_EQ(f.discarded(), 0u);
}

TEST(ClientFramer, CompletesAnExceptionReplyAtFiveBytes) {
  ClientFramer f;
  f.expect(1, WriteCoilRequest{0x19, kCoilOn});
  Bytes ex{0x01, 0x85, 0x02};
  append_crc(ex);
  EXPECT_EQ(f.feed(ex), ClientFramer::Status::Complete);
  EXPECT_EQ(f.frame().size(), 5u);
}

TEST(ClientFramer, ResynchronisesAfterGarbageAndReportsIt) {
  auto f = framer_for_read_position();
  Bytes stream = {0x00, 0xFF, 0x01, 0x07, 0x01, 0x03, 0x09};  // noise, wrong FC, wrong byte count
  stream.insert(stream.end(), kPositionReply.begin(), kPositionReply.end());
  ASSERT_EQ(f.feed(stream), ClientFramer::Status::Complete);
  EXPECT_EQ(to_hex(f.frame()), to_hex(kPositionReply));
  EXPECT_EQ(f.discarded(), 7u);
}

TEST(ClientFramer, BadCrcCandidateIsDroppedAndCounted) {
  auto f = framer_for_read_position();
  Bytes corrupted = kPositionReply;
  corrupted[4] ^= 0x10;
  EXPECT_EQ(f.feed(corrupted), ClientFramer::Status::Incomplete);
  EXPECT_EQ(f.crc_failures(), 1u);
  EXPECT_EQ(f.last_discard(), ClientFramer::Discard::BadCrc);
  // The real reply after it still completes.
  EXPECT_EQ(f.feed(kPositionReply), ClientFramer::Status::Complete);
  EXPECT_EQ(to_hex(f.frame()), to_hex(kPositionReply));
}

TEST(ClientFramer, RepliesOfAnotherIdAreNeverAccepted) {
  ClientFramer f;
  f.expect(2, ReadRegistersRequest{0x9000, 2});
  EXPECT_EQ(f.feed(kPositionReply), ClientFramer::Status::Incomplete);
  EXPECT_GE(f.discarded(), 1u);
}

TEST(ClientFramer, RandomStreamsNeverYieldAFrameWithABadCrc) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5000; ++trial) {
    auto f = framer_for_read_position();
    Bytes noise(rng() % 64);
    for (auto& b : noise) b = static_cast<uint8_t>(rng() % 4 == 0 ? 0x01 : rng());
    if (f.feed(noise) == ClientFramer::Status::Complete) {
      auto d = decode_response(f.frame());
      ASSERT_TRUE(d) << to_hex(f.frame());
      ASSERT_EQ(d->id, 1);
    }
  }
}

TEST(DeviceFramer, DelimitsFramesBySilentInterval) {
  LineTiming timing;  // 38400: Ts = 0.911 ms
  DeviceFramer f(timing.silent_interval(), FrameEnd::Silence);
  TimePoint t{};
  const Duration byte = timing.char_time();
  for (uint8_t b : kReadPosition) {
    f.feed(std::span(&b, 1), t);
    t += byte;
  }
  const TimePoint last = t - byte;
  EXPECT_FALSE(f.poll(last + timing.silent_interval() - Duration(1)));
  ASSERT_EQ(f.deadline(), last + timing.silent_interval());
  auto frame = f.poll(last + timing.silent_interval());
  ASSERT_TRUE(frame);
  EXPECT_EQ(to_hex(frame->bytes), to_hex(kReadPosition));
  EXPECT_EQ(frame->end_of_query, last);
}

TEST(DeviceFramer, GapShorterThanTsContinuesTheFrame) {
  LineTiming timing;
  DeviceFramer f(timing.silent_interval(), FrameEnd::Silence);
  const Duration almost = timing.silent_interval() - Duration(1000);
  f.feed(std::span(kReadPosition).first(3), TimePoint{});
  f.feed(std::span(kReadPosition).subspan(3), TimePoint{} + almost);
  auto frame = f.poll(TimePoint{} + almost + timing.silent_interval());
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->bytes.size(), kReadPosition.size());
}

TEST(DeviceFramer, GapOfTsSplitsTwoFrames) {
  LineTiming timing;
  DeviceFramer f(timing.silent_interval(), FrameEnd::Silence);
  f.feed(std::span(kReadPosition).first(3), TimePoint{});
  f.feed(std::span(kReadPosition).subspan(3), TimePoint{} + timing.silent_interval());
  auto first = f.poll(TimePoint{} + 3 * timing.silent_interval());
  auto second = f.poll(TimePoint{} + 3 * timing.silent_interval());
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->bytes.size(), 3u);
  EXPECT_EQ(second->bytes.size(), 5u);
}

TEST(DeviceFramer, FastModeCompletesOnLengthWithValidCrc) {
  LineTiming timing;
  DeviceFramer f(timing.silent_interval(), FrameEnd::LengthOrSilence);
  Bytes two = kReadPosition;
  two.insert(two.end(), kReadPosition.begin(), kReadPosition.end());
  f.feed(two, TimePoint{});
  auto a = f.poll(TimePoint{});
  auto b = f.poll(TimePoint{});
  ASSERT_TRUE(a && b);
  EXPECT_EQ(to_hex(a->bytes), to_hex(kReadPosition));
  EXPECT_EQ(to_hex(b->bytes), to_hex(kReadPosition));
}

TEST(DeviceFramer, FastModeFallsBackToTsForFramesItCannotSize) {
  LineTiming timing;
  DeviceFramer f(timing.silent_interval(), FrameEnd::LengthOrSilence);
  Bytes unknown{0x01, 0x06, 0x00, 0x01, 0x00, 0x03};
  append_crc(unknown);
  f.feed(unknown, TimePoint{});
  EXPECT_FALSE(f.poll(TimePoint{}));
  EXPECT_TRUE(f.poll(TimePoint{} + timing.silent_interval()));
}

TEST(DeviceFramer, AnEndlessStreamIsBounded) {
  DeviceFramer f(std::chrono::milliseconds(1), FrameEnd::Silence);
  Bytes junk(1000, 0x55);
  f.feed(junk, TimePoint{});
  auto frame = f.poll(TimePoint{} + std::chrono::milliseconds(2));
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->bytes.size(), kMaxAdu + 1);
  EXPECT_EQ(f.overflowed(), 1000 - kMaxAdu - 1);
}

TEST(DeviceFramer, AnOverLongFrameIsJudgedByItsWholeCrc) {
  DeviceFramer f(std::chrono::milliseconds(1), FrameEnd::Silence);
  Bytes sound(300, 0x42);
  sound[0] = 0x01;
  append_crc(sound);
  f.feed(std::span(sound).first(100), TimePoint{});
  f.feed(std::span(sound).subspan(100), TimePoint{});
  auto frame = f.poll(TimePoint{} + std::chrono::milliseconds(2));
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->length, 302u);
  EXPECT_EQ(frame->bytes.size(), kMaxAdu + 1);
  EXPECT_TRUE(frame->long_crc_ok);
  sound[280] ^= 0x01;
  f.feed(sound, TimePoint{} + std::chrono::milliseconds(10));
  frame = f.poll(TimePoint{} + std::chrono::milliseconds(20));
  ASSERT_TRUE(frame);
  EXPECT_FALSE(frame->long_crc_ok);
  // A frame within the limit is not "long": its CRC is checked as usual.
  Bytes ok{0x01, 0x03, 0x90, 0x00, 0x00, 0x07};
  append_crc(ok);
  f.feed(ok, TimePoint{} + std::chrono::milliseconds(30));
  frame = f.poll(TimePoint{} + std::chrono::milliseconds(40));
  EXPECT_EQ(frame->length, ok.size());
  EXPECT_FALSE(frame->long_crc_ok);
}

TEST(Crc, UpdateContinuesACrc) {
  const Bytes a{0x01, 0x03, 0x90}, b{0x00, 0x00, 0x07};
  Bytes ab = a;
  ab.insert(ab.end(), b.begin(), b.end());
  EXPECT_EQ(crc16_update(crc16(a), b), crc16(ab));
  append_crc(ab);
  EXPECT_EQ(crc16(ab), 0);  // a frame with its CRC appended has CRC 0
}

TEST(Timing, ManualResponseTimeExample) {
  // §8.4 / digest §1: read 2 registers at 38400, k=1, Td=5: Tx ≈ 14.3 ms.
  LineTiming t;
  EXPECT_NEAR(to_ms(t.silent_interval()), 0.911, 0.001);
  EXPECT_NEAR(to_ms(t.wire_time(9)), 2.344, 0.001);
  EXPECT_NEAR(to_ms(t.response_time(9)), 14.255, 0.01);
  // The limit for a D9000×7 read: query 8 bytes, reply 19 bytes.
  EXPECT_NEAR(to_ms(t.transaction_limit(8, 19)), 2.083 + 0.911 + 4 + 5 + 4.948, 0.01);
  EXPECT_TRUE(is_supported_baud(230400));
  EXPECT_FALSE(is_supported_baud(14400));
}

}  // namespace
}  // namespace lec6::modbus
