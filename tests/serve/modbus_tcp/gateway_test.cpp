// What a request from a TCP master becomes (gateway.hpp), one rule per case.

#include "modbus_tcp/gateway.hpp"

#include <gtest/gtest.h>

namespace lec6::serve {
namespace {

using modbus::Bytes;
using modbus::ExceptionCode;

GatewayPolicy policy() {
  GatewayPolicy p;
  p.units = {1, 2};
  p.cache_max_age = std::chrono::milliseconds(200);
  p.read_retries = 2;
  return p;
}

std::optional<ExceptionCode> local_code(const GatewayDecision& d) {
  if (const auto* l = std::get_if<LocalAnswer>(&d)) {
    return std::get<modbus::ExceptionResponse>(l->pdu).code;
  }
  return std::nullopt;
}

const Bytes kReadState = {0x03, 0x90, 0x00, 0x00, 0x07};
const Bytes kSvonOn = {0x05, 0x00, 0x19, 0xFF, 0x00};

TEST(Gateway, ReadsQueueWithCacheAndRetriesWritesWithout) {
  auto read = std::get<LineRequest>(decide(policy(), 1, kReadState));
  EXPECT_EQ(read.frame.id, 1);
  EXPECT_EQ(read.attempts, 3);
  EXPECT_EQ(read.max_cache_age, std::chrono::milliseconds(200));
  auto write = std::get<LineRequest>(decide(policy(), 2, kSvonOn));
  EXPECT_EQ(write.attempts, 1);
  EXPECT_EQ(write.max_cache_age, Duration{});
}

TEST(Gateway, RefusalsAnsweredWithoutTheLine) {
  EXPECT_EQ(local_code(decide(policy(), 9, kReadState)), ExceptionCode::GatewayPathUnavailable);
  EXPECT_EQ(local_code(decide(policy(), 0, kSvonOn)), ExceptionCode::GatewayPathUnavailable);
  auto no_fc06 = policy();
  no_fc06.accept_fc06 = false;
  EXPECT_EQ(local_code(decide(no_fc06, 1, Bytes{0x06, 0x91, 0x02, 0x00, 0x01})),
            ExceptionCode::IllegalFunction);
  EXPECT_EQ(local_code(decide(policy(), 1, Bytes{0x03, 0x50, 0x00, 0x00, 0x01})),
            ExceptionCode::IllegalAddress);  // outside the map: the controller's 02
  EXPECT_EQ(local_code(decide(policy(), 1, Bytes{0x03, 0x90, 0x00, 0x00, 0x7E})),
            ExceptionCode::IllegalAccessRange);  // 126 registers
  EXPECT_EQ(local_code(decide(policy(), 1, Bytes{0x03, 0x90})), ExceptionCode::IllegalAccessRange);
  auto ro = policy();
  ro.read_only = true;
  EXPECT_EQ(local_code(decide(ro, 1, kSvonOn)), ExceptionCode::IllegalFunction);
  EXPECT_TRUE(std::holds_alternative<LineRequest>(decide(ro, 1, kReadState)));
}

TEST(Gateway, BroadcastOnlyWhenAllowedAndOnlyWrites) {
  auto p = policy();
  p.allow_broadcast = true;
  EXPECT_EQ(std::get<LineRequest>(decide(p, 0, kSvonOn)).frame.id, 0);
  EXPECT_EQ(local_code(decide(p, 0, kReadState)), ExceptionCode::GatewayPathUnavailable);
}

// Issue 33 rule 4: FC06 through lec serve, as the one-register FC10, answered
// as FC06's echo, under the same checks and the same stop rule.
TEST(Gateway, AnFc06IsWrittenAsFc10AndAnsweredWithItsEcho) {
  const Bytes fc06 = {0x06, 0x91, 0x02, 0x00, 0x01};  // D9102 <- 1
  const auto line = std::get<LineRequest>(decide(policy(), 1, fc06));
  EXPECT_EQ(line.frame.pdu,
            modbus::Request(modbus::WriteRegistersRequest{0x9102, 1, {0x00, 0x01}}));
  EXPECT_EQ(line.priority, Priority::Command);
  ASSERT_TRUE(line.fc06_echo);
  JobResult ok;
  ok.reply = modbus::ResponseFrame{
      1, modbus::WriteMultipleResponse{modbus::FunctionCode::WriteRegisters, 0x9102, 1}};
  EXPECT_EQ(tcp_reply_pdu(line, ok), fc06) << "the echo, as a controller answers FC06";
  JobResult refused;
  refused.reply =
      modbus::ResponseFrame{1, modbus::ExceptionResponse{modbus::FunctionCode::WriteRegisters, 0x10,
                                                         ExceptionCode::IllegalAddress}};
  EXPECT_EQ(tcp_reply_pdu(line, refused), (Bytes{0x86, 0x02})) << "an exception names FC06";
  JobResult lost;
  lost.failure = Failure::NoAnswer;
  EXPECT_EQ(tcp_reply_pdu(line, lost), (Bytes{0x86, 0x0B}));
}

TEST(Gateway, AnFc06HoldToTheControlWordIsAStop) {
  // D90C1 = SVON | HOLD (Y19, Y18): a PLC's HOLD as a word, by FC06.
  const auto hold = std::get<LineRequest>(decide(policy(), 1, Bytes{0x06, 0x90, 0xC1, 0x03, 0x00}));
  EXPECT_EQ(hold.priority, Priority::Emergency);
  const auto run = std::get<LineRequest>(decide(policy(), 1, Bytes{0x06, 0x90, 0xC1, 0x06, 0x00}));
  EXPECT_EQ(run.priority, Priority::Command) << "SVON | DRIVE starts: a command";
}

TEST(Gateway, AnFc06GetsTheChecksOfItsFc10) {
  EXPECT_EQ(local_code(decide(policy(), 1, Bytes{0x06, 0x90, 0x00, 0x00, 0x01})),
            ExceptionCode::IllegalAddress)
      << "D9000 is read-only";
  EXPECT_EQ(local_code(decide(policy(), 1, Bytes{0x06, 0x91, 0x02, 0x00})),
            ExceptionCode::IllegalAccessRange)
      << "a short FC06";
  auto ro = policy();
  ro.read_only = true;
  EXPECT_EQ(local_code(decide(ro, 1, Bytes{0x06, 0x91, 0x02, 0x00, 0x01})),
            ExceptionCode::IllegalFunction);
  const auto d = decide(policy(), 1, Bytes{0x06, 0x90, 0x00, 0x00, 0x01});
  const auto* l = std::get_if<LocalAnswer>(&d);
  ASSERT_TRUE(l);
  EXPECT_EQ(modbus::encode_response_pdu(l->pdu)[0], 0x86);
}

// An FC06 to unit 0 (broadcast, when the listener allows it): the line
// carries no reply, so the gateway answers for the controllers, and to an
// FC06 that answer is FC06's echo. Found in review: it was FC10's reply
// (10 91 02 00 01), which an FC06 master takes for a garbled answer.
TEST(Gateway, ABroadcastFc06IsAnsweredWithItsEcho) {
  auto p = policy();
  p.allow_broadcast = true;
  const Bytes fc06 = {0x06, 0x91, 0x02, 0x00, 0x01};
  const auto line = std::get<LineRequest>(decide(p, 0, fc06));
  EXPECT_EQ(line.frame.id, 0);
  JobResult sent;  // a broadcast: written, no reply
  EXPECT_EQ(tcp_reply_pdu(line, sent), fc06);
}

TEST(Gateway, FailedJobsBecomeGatewayExceptions) {
  const modbus::RequestFrame frame{1, modbus::ReadRegistersRequest{0x9000, 7}};
  const auto code = [&](Failure f) {
    JobResult r;
    r.failure = f;
    auto reply = tcp_reply(frame, r);
    return reply ? std::optional(std::get<modbus::ExceptionResponse>(*reply).code) : std::nullopt;
  };
  EXPECT_EQ(code(Failure::NoAnswer), ExceptionCode::GatewayTargetFailed);
  EXPECT_EQ(code(Failure::Offline), ExceptionCode::GatewayTargetFailed);
  EXPECT_EQ(code(Failure::LineDown), ExceptionCode::GatewayPathUnavailable);
  EXPECT_EQ(code(Failure::ShuttingDown), ExceptionCode::ServerBusy);
  EXPECT_EQ(code(Failure::Cancelled), std::nullopt);
  // A broadcast write is owed the reply a controller would have given.
  JobResult ok;
  ok.reply = modbus::ResponseFrame{0, modbus::WriteMultipleResponse{}};
  const auto echo = tcp_reply({0, modbus::WriteCoilRequest{0x19, modbus::kCoilOn}}, ok);
  EXPECT_EQ(std::get<modbus::WriteCoilResponse>(*echo),
            (modbus::WriteCoilResponse{0x19, modbus::kCoilOn}));
}

}  // namespace
}  // namespace lec6::serve
