// The transaction state machine driven by hand: bytes and time points in,
// steps out. No link, no clock.

#include "lec6/client/transaction.hpp"

#include <gtest/gtest.h>

namespace lec6::client {
namespace {

using modbus::from_hex;

const modbus::RequestFrame kReadPosition{1, modbus::ReadRegistersRequest{0x9000, 2}};
const modbus::Bytes kReply = *from_hex("01 03 04 00 00 3A 98 E9 39");

TransactionTiming timing() {
  return TransactionTiming{modbus::LineTiming{}, std::chrono::milliseconds(50)};
}

TEST(Transaction, SendsTheEncodedQueryThenWaitsUntilTxPlusMargin) {
  Transaction tx(kReadPosition, timing());
  ASSERT_EQ(tx.step(), Transaction::Step::Send);
  EXPECT_EQ(modbus::to_hex(tx.bytes()), "01 03 90 00 00 02 E9 0B");
  const TimePoint t0{};
  tx.sent(t0);
  ASSERT_EQ(tx.step(), Transaction::Step::Receive);
  // Tx for a 9-byte reply at 38400 (manual §8.4) is about 14.3 ms; plus 50 ms.
  EXPECT_NEAR(to_ms(tx.deadline() - t0), 14.255 + 50, 0.01);
}

TEST(Transaction, CompletesOnTheLastByteOfTheReply) {
  Transaction tx(kReadPosition, timing());
  tx.sent(TimePoint{});
  tx.received(std::span(kReply).first(5), TimePoint{} + std::chrono::milliseconds(10));
  EXPECT_EQ(tx.step(), Transaction::Step::Receive);
  tx.received(std::span(kReply).subspan(5), TimePoint{} + std::chrono::milliseconds(12));
  ASSERT_EQ(tx.step(), Transaction::Step::Done);
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(tx.response().pdu).values,
            (std::vector<uint16_t>{0x0000, 0x3A98}));
  EXPECT_EQ(tx.finished_at(), TimePoint{} + std::chrono::milliseconds(12));
}

TEST(Transaction, TimeoutIsClassifiedByWhatArrived) {
  {
    Transaction tx(kReadPosition, timing());
    tx.sent(TimePoint{});
    tx.timed_out(tx.deadline());
    EXPECT_EQ(tx.step(), Transaction::Step::Failed);
    EXPECT_EQ(tx.error_kind(), TransportErrorKind::Timeout);
  }
  {
    Transaction tx(kReadPosition, timing());
    tx.sent(TimePoint{});
    auto corrupted = kReply;
    corrupted[4] ^= 0x01;
    tx.received(corrupted, TimePoint{} + std::chrono::milliseconds(14));
    tx.timed_out(tx.deadline());
    EXPECT_EQ(tx.error_kind(), TransportErrorKind::Crc);
  }
  {
    Transaction tx(kReadPosition, timing());
    tx.sent(TimePoint{});
    tx.received(*from_hex("55 AA 55"), TimePoint{} + std::chrono::milliseconds(14));
    tx.timed_out(tx.deadline());
    EXPECT_EQ(tx.error_kind(), TransportErrorKind::Framing);
  }
}

TEST(Transaction, ExceptionReplyCompletesAtFiveBytes) {
  Transaction tx({1, modbus::WriteCoilRequest{0x19, modbus::kCoilOn}}, timing());
  tx.sent(TimePoint{});
  tx.received(*from_hex("01 85 02 C3 51"), TimePoint{} + std::chrono::milliseconds(11));
  ASSERT_EQ(tx.step(), Transaction::Step::Done);
  EXPECT_EQ(std::get<modbus::ExceptionResponse>(tx.response().pdu).code,
            modbus::ExceptionCode::IllegalAddress);
}

TEST(Transaction, BroadcastWaitsTxAndIgnoresStrayBytes) {
  Transaction tx({0, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}}, timing());
  tx.sent(TimePoint{});
  EXPECT_NEAR(to_ms(tx.deadline() - TimePoint{}), to_ms(modbus::LineTiming{}.response_time(8)),
              0.001);  // Tx
  tx.received(*from_hex("00 05 00 30 FF 00"), TimePoint{} + std::chrono::milliseconds(1));
  EXPECT_EQ(tx.step(), Transaction::Step::Receive);
  tx.timed_out(tx.deadline());
  EXPECT_EQ(tx.step(), Transaction::Step::Done);
  EXPECT_FALSE(tx.maybe_response());
}

TEST(Transaction, RefusesToEncodeWhatTheControllerRefuses) {
  EXPECT_THROW(Transaction({1, modbus::ReadRegistersRequest{0x9000, 0}}, timing()), InvalidRequest);
}

}  // namespace
}  // namespace lec6::client
