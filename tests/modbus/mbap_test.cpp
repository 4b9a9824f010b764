// MBAP framing (Modbus TCP), sans-I/O: header fields, streams cut anywhere,
// and streams that cannot be framed.

#include "lec6/modbus/mbap.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::modbus {
namespace {

using ::testing::HasSubstr;

// Read D9000×7 for unit 1, transaction 0x1234 (as a PLC would send it).
const Bytes kReadState = {0x12, 0x34, 0x00, 0x00, 0x00, 0x06, 0x01, 0x03, 0x90, 0x00, 0x00, 0x07};

TEST(Mbap, EncodesTheHeaderTheSpecificationGives) {
  const auto pdu = encode_request_pdu(ReadRegistersRequest{0x9000, 7});
  ASSERT_TRUE(pdu);
  EXPECT_EQ(to_hex(encode_mbap(0x1234, 1, *pdu)), to_hex(kReadState));
}

TEST(Mbap, PduCodecMatchesTheRtuCodecWithoutIdAndCrc) {
  const RequestFrame frame{7, WriteCoilRequest{0x19, kCoilOn}};
  const auto adu = encode_request(frame);
  const auto pdu = encode_request_pdu(frame.pdu);
  ASSERT_TRUE(adu && pdu);
  EXPECT_EQ(Bytes(adu->begin() + 1, adu->end() - 2), *pdu);
  const auto back = decode_request_pdu(*pdu);
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, frame.pdu);
}

TEST(Mbap, FramesAStreamCutAtEveryByte) {
  Bytes stream = kReadState;
  const Bytes second = encode_mbap(0x0001, 2, Bytes{0x02, 0x00, 0x40, 0x00, 0x10});
  stream.insert(stream.end(), second.begin(), second.end());
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    MbapFramer f;
    std::vector<MbapAdu> got;
    f.feed(std::span(stream).first(cut));
    while (auto a = f.next()) got.push_back(*a);
    f.feed(std::span(stream).subspan(cut));
    while (auto a = f.next()) got.push_back(*a);
    ASSERT_EQ(got.size(), 2u) << "cut at " << cut;
    EXPECT_EQ(got[0].header, (MbapHeader{0x1234, 0, 6, 1}));
    EXPECT_EQ(to_hex(got[0].pdu), "03 90 00 00 07");
    EXPECT_EQ(got[1].header.unit, 2);
    EXPECT_EQ(f.status(), MbapFramer::Status::Incomplete);
  }
}

TEST(Mbap, AWrongProtocolIdBreaksTheStream) {
  Bytes bad = kReadState;
  bad[3] = 0x01;
  MbapFramer f;
  EXPECT_EQ(f.feed(bad), MbapFramer::Status::Broken);
  EXPECT_FALSE(f.next());
  EXPECT_THAT(f.error(), HasSubstr("protocol id 1"));
}

TEST(Mbap, ALyingLengthBreaksTheStreamAtOnce) {
  // Length 0xFFFF: waiting for it would hold the connection forever.
  MbapFramer f;
  EXPECT_EQ(f.feed(Bytes{0, 1, 0, 0, 0xFF, 0xFF, 1}), MbapFramer::Status::Broken);
  EXPECT_THAT(f.error(), HasSubstr("length 65535"));
  MbapFramer g;
  EXPECT_EQ(g.feed(Bytes{0, 1, 0, 0, 0, 1, 1}), MbapFramer::Status::Broken);  // no PDU at all
}

TEST(Mbap, RtuBytesSentToAModbusTcpPortAreRecognised) {
  MbapFramer f;
  // 01 03 90 00 00 07 + CRC: bytes 2–3 (protocol id) read 0x9000.
  EXPECT_EQ(f.feed(Bytes{0x01, 0x03, 0x90, 0x00, 0x00, 0x07, 0xE8, 0xC8}),
            MbapFramer::Status::Broken);
  EXPECT_THAT(f.error(), HasSubstr("not a Modbus TCP peer"));
}

TEST(Mbap, AnAduAfterABrokenOneIsNotServed) {
  Bytes stream = kReadState;
  stream.insert(stream.end(), {0, 2, 0, 7, 0, 6, 1});  // protocol id 7
  MbapFramer f;
  f.feed(stream);
  EXPECT_TRUE(f.next());
  EXPECT_FALSE(f.next());
  EXPECT_EQ(f.status(), MbapFramer::Status::Broken);
}

TEST(Mbap, GatewayExceptionsDecodeOnlyFromAGateway) {
  const Bytes ex0b = {0x83, 0x0B};
  EXPECT_FALSE(decode_response_pdu(ex0b));
  const auto r = decode_response_pdu(ex0b, ExceptionSource::Gateway);
  ASSERT_TRUE(r);
  EXPECT_EQ(std::get<ExceptionResponse>(*r).code, ExceptionCode::GatewayTargetFailed);
  EXPECT_FALSE(decode_response_pdu(Bytes{0x83, 0x07}, ExceptionSource::Gateway));
}

TEST(Mbap, EmptyPdusAreRefusedNotRead) {
  EXPECT_FALSE(decode_request_pdu({}));
  EXPECT_FALSE(decode_response_pdu({}));
}

}  // namespace
}  // namespace lec6::modbus
