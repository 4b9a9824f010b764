#include "lec6/modbus/pdu.hpp"

#include <gtest/gtest.h>

#include <random>

#include "golden_frames.hpp"
#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"

namespace lec6::modbus {
namespace {

Bytes with_crc(Bytes body) {
  append_crc(body);
  return body;
}

TEST(Encode, RefusesCountsTheControllerRefuses) {
  auto r = encode_request({1, ReadRegistersRequest{0x9000, 126}});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().kind, ErrorKind::CountOutOfRange);
  EXPECT_NE(r.error().message.find("1 to 125"), std::string::npos) << r.error().message;
  EXPECT_FALSE(encode_request({1, ReadRegistersRequest{0x9000, 0}}));
  EXPECT_FALSE(encode_request({1, ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 2001}}));
  EXPECT_TRUE(encode_request({1, ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 2000}}));
  std::vector<uint16_t> regs(124, 0);
  EXPECT_FALSE(encode_request({1, WriteRegistersRequest::of(0x0400, regs)}));
  regs.resize(123);
  EXPECT_TRUE(encode_request({1, WriteRegistersRequest::of(0x0400, regs)}));
  auto bad = encode_request({1, WriteCoilRequest{0x19, 0x1234}});
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().kind, ErrorKind::BadValue);
}

TEST(Encode, ResponsesOfEveryFunction) {
  EXPECT_EQ(
      to_hex(encode_response({3, WriteMultipleResponse{FunctionCode::WriteCoils, 0x10, 0x10}})),
      to_hex(with_crc({3, 0x0F, 0x00, 0x10, 0x00, 0x10})));
  EXPECT_EQ(to_hex(encode_response({3, ExceptionResponse{FunctionCode::ReadCoils, 0x01,
                                                         ExceptionCode::IllegalFunction}})),
            to_hex(with_crc({3, 0x81, 0x01})));
  // An exception to an unknown function code echoes the code it was given.
  EXPECT_EQ(to_hex(encode_response({1, ExceptionResponse{FunctionCode::ReadCoils, 0x06,
                                                         ExceptionCode::IllegalFunction}})),
            to_hex(with_crc({1, 0x86, 0x01})));
}

TEST(Decode, ManualSection9Examples) {
  // §9.1 reply for Y10..Y1F = 0001 0010 0000 0000: data 00 12.
  auto r = decode_response(with_crc({3, 0x01, 0x02, 0x00, 0x12}));
  ASSERT_TRUE(r);
  const auto& bits = std::get<ReadBitsResponse>(r->pdu);
  EXPECT_TRUE(bits.bit(9));   // Y19 SVON
  EXPECT_TRUE(bits.bit(12));  // Y1C SETUP
  EXPECT_FALSE(bits.bit(0));
  // §9.6 request: Y10..Y1F = 0001 0010 0000 1111.
  auto q = decode_request(with_crc({3, 0x0F, 0x00, 0x10, 0x00, 0x10, 0x02, 0x0F, 0x12}));
  ASSERT_TRUE(q);
  const auto& w = std::get<WriteCoilsRequest>(q->pdu);
  EXPECT_EQ(w.count, 16);
  EXPECT_TRUE(w.bit(0) && w.bit(3) && w.bit(9) && w.bit(12));
  EXPECT_FALSE(w.bit(4));
}

TEST(Decode, TypedErrorsNameTheProblem) {
  auto short_frame = decode_response(Bytes{0x01, 0x03});
  ASSERT_FALSE(short_frame);
  EXPECT_EQ(short_frame.error().kind, ErrorKind::ShortFrame);

  auto bad_crc = decode_response(Bytes{0x01, 0x03, 0x02, 0x00, 0x01, 0x00, 0x00});
  ASSERT_FALSE(bad_crc);
  EXPECT_EQ(bad_crc.error().kind, ErrorKind::BadCrc);
  EXPECT_NE(bad_crc.error().message.find("CRC"), std::string::npos);

  auto unknown = decode_request(with_crc({1, 0x06, 0x00, 0x01, 0x00, 0x03}));
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().kind, ErrorKind::UnknownFunction);
  EXPECT_NE(unknown.error().message.find("06h"), std::string::npos);

  auto count = decode_response(with_crc({1, 0x03, 0x04, 0x00, 0x01}));
  ASSERT_FALSE(count);
  EXPECT_EQ(count.error().kind, ErrorKind::BadByteCount);

  auto odd = decode_response(with_crc({1, 0x03, 0x03, 0x00, 0x01, 0x02}));
  ASSERT_FALSE(odd);
  EXPECT_EQ(odd.error().kind, ErrorKind::BadByteCount);

  auto trailing = decode_request(with_crc({1, 0x03, 0x90, 0x00, 0x00, 0x02, 0x55}));
  ASSERT_FALSE(trailing);
  EXPECT_EQ(trailing.error().kind, ErrorKind::LongFrame);

  auto bad_exception = decode_response(with_crc({1, 0x83, 0x07}));
  ASSERT_FALSE(bad_exception);
}

TEST(Decode, StructuralDecodeKeepsBadCountsForTheController) {
  // Count 0 and a byte count that disagrees with the count are still decoded:
  // the controller answers them with exception 03, so the twin must see them.
  auto zero = decode_request(with_crc({1, 0x03, 0x90, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(zero);
  EXPECT_EQ(std::get<ReadRegistersRequest>(zero->pdu).count, 0);
  auto mismatch = decode_request(with_crc({1, 0x10, 0x04, 0x00, 0x00, 0x02, 0x02, 0x00, 0x01}));
  ASSERT_TRUE(mismatch);
  EXPECT_EQ(std::get<WriteRegistersRequest>(mismatch->pdu).data.size(), 2u);
}

TEST(Decode, TruncatedGoldenFramesNeverDecodeAndNeverOverread) {
  for (const auto& g : testing::load_golden_frames()) {
    for (std::size_t n = 0; n < g.bytes.size(); ++n) {
      // A copy of exactly n bytes, so ASan sees any read past the end.
      const Bytes cut(g.bytes.begin(), g.bytes.begin() + static_cast<std::ptrdiff_t>(n));
      EXPECT_FALSE(decode_request(cut)) << g.section << " cut to " << n;
      EXPECT_FALSE(decode_response(cut)) << g.section << " cut to " << n;
    }
  }
}

TEST(Decode, CorruptedGoldenFramesAreRejected) {
  std::mt19937 rng(7);
  for (const auto& g : testing::load_golden_frames()) {
    for (int trial = 0; trial < 200; ++trial) {
      Bytes copy = g.bytes;
      const std::size_t at = rng() % copy.size();
      const auto flip = static_cast<uint8_t>(1 + rng() % 255);
      copy[at] = static_cast<uint8_t>(copy[at] ^ flip);
      if (crc_ok(copy)) continue;  // 16-bit CRC: a changed byte always changes it, but be exact
      auto decode = g.query ? decode_request(copy).has_value() : decode_response(copy).has_value();
      EXPECT_FALSE(decode) << g.section << " byte " << at;
    }
  }
}

TEST(Decode, RandomBytesWithValidCrcNeverCrash) {
  std::mt19937 rng(99);
  for (int n = 0; n < 20000; ++n) {
    Bytes body(2 + rng() % 40);
    for (auto& b : body) b = static_cast<uint8_t>(rng());
    if (rng() % 2)
      body[1] = static_cast<uint8_t>(std::array<int, 8>{1, 2, 3, 5, 8, 15, 16, 0x83}[rng() % 8]);
    const Bytes adu = with_crc(body);
    auto q = decode_request(adu);
    auto r = decode_response(adu);
    if (q) {
      // Whatever decodes re-encodes to the same bytes (when its counts are legal).
      auto again = encode_request(*q);
      if (again) {
        EXPECT_EQ(to_hex(*again), to_hex(adu));
      }
    }
    if (r) {
      EXPECT_EQ(to_hex(encode_response(*r)), to_hex(adu));
    }
  }
}

TEST(Hex, ParsesCommonSpellings) {
  EXPECT_EQ(to_hex(*from_hex("01 05 00 30")), "01 05 00 30");
  EXPECT_EQ(to_hex(*from_hex("01050030")), "01 05 00 30");
  EXPECT_EQ(to_hex(*from_hex("0x01,0x05")), "01 05");
  EXPECT_FALSE(from_hex("0 1"));
  EXPECT_FALSE(from_hex("zz"));
  EXPECT_FALSE(from_hex("123"));
}

TEST(Length, PredictsRequestsAndReplies) {
  using S = FrameLength::Status;
  EXPECT_EQ(request_length(Bytes{0x01}).status, S::NeedMore);
  EXPECT_EQ(request_length(Bytes{0x01, 0x03}).bytes, 8u);
  EXPECT_EQ(request_length(Bytes{0x01, 0x10, 0x91, 0x02, 0x00, 0x10}).status, S::NeedMore);
  EXPECT_EQ(request_length(Bytes{0x01, 0x10, 0x91, 0x02, 0x00, 0x10, 0x20}).bytes, 41u);
  EXPECT_EQ(request_length(Bytes{0x01, 0x06}).status, S::Unknown);
  EXPECT_EQ(response_length(Bytes{0x01, 0x83}).bytes, 5u);
  EXPECT_EQ(response_length(Bytes{0x01, 0x03}).status, S::NeedMore);
  EXPECT_EQ(response_length(Bytes{0x01, 0x03, 0x04}).bytes, 9u);
  EXPECT_EQ(response_length(Bytes{0x01, 0x05}).bytes, 8u);
  for (const auto& g : testing::load_golden_frames()) {
    const auto len = g.query ? request_length(g.bytes) : response_length(g.bytes);
    EXPECT_EQ(len.status, S::Known);
    EXPECT_EQ(len.bytes, g.bytes.size()) << g.section;
  }
}

TEST(Length, ExpectedResponseLengthMatchesEncodedReplies) {
  EXPECT_EQ(expected_response_length(ReadRegistersRequest{0x9000, 7}), 19u);
  EXPECT_EQ(expected_response_length(ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16}), 7u);
  EXPECT_EQ(expected_response_length(ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 33}), 10u);
  EXPECT_EQ(expected_response_length(WriteCoilRequest{0x19, kCoilOn}), 8u);
}

}  // namespace
}  // namespace lec6::modbus
