// The capture format's codec: round trip, and every refusal names the file,
// the line and the byte offset of that line.

#include "lec6/modbus/capture.hpp"

#include <chrono>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::modbus {
namespace {

using ::testing::HasSubstr;

CaptureHeader sample_header() {
  CaptureHeader h;
  h.source = "sniff";
  h.started_utc = "2026-11-24T19:00:00.123456Z";
  h.line = {115200, 'N', 8, 2};
  h.port = "/dev/ttyUSB1";
  h.tool = "lec 0.1.0";
  return h;
}

const std::string kHeader =
    R"({"format":"lec6-capture","version":1,"source":"sniff","started_utc":"2026-11-24T19:00:00Z"})"
    "\n";

// The error parse_capture throws for `text` (fails the test if none).
CaptureError error_of(const std::string& text) {
  try {
    parse_capture(text, "capture.jsonl");
  } catch (const CaptureError& e) {
    return e;
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return CaptureError("none", 0, 0, "none");
}

TEST(Capture, HeaderAndRecordsRoundTrip) {
  Capture c;
  c.header = sample_header();
  c.records.push_back({1234, 1900, CaptureDir::Query, {0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A}, ""});
  c.records.push_back({5000, 5600, CaptureDir::Reply, {0x01, 0x83, 0x02, 0xC0, 0xF1}, "exception \"2\"\n"});
  c.records.push_back({5600, 5600, CaptureDir::Noise, {0xFF}, ""});
  c.records.push_back({7000, 7100, CaptureDir::Unknown, {0x00, 0xAB}, ""});
  std::string text = encode_capture_header(c.header);
  for (const auto& r : c.records) text += encode_capture_record(r);

  const Capture back = parse_capture(text, "x.jsonl");
  EXPECT_EQ(back.header.version, 1);
  EXPECT_EQ(back.header.source, "sniff");
  EXPECT_EQ(back.header.started_utc, "2026-11-24T19:00:00.123456Z");
  EXPECT_EQ(back.header.line.baud, 115200u);
  EXPECT_EQ(back.header.line.parity, 'N');
  EXPECT_EQ(back.header.line.data_bits, 8);
  EXPECT_EQ(back.header.line.stop_bits, 2);
  EXPECT_EQ(back.header.port, "/dev/ttyUSB1");
  EXPECT_EQ(back.header.tool, "lec 0.1.0");
  ASSERT_EQ(back.records.size(), c.records.size());
  for (std::size_t i = 0; i < c.records.size(); ++i) {
    EXPECT_EQ(back.records[i].t_us, c.records[i].t_us);
    EXPECT_EQ(back.records[i].end_us, c.records[i].end_us);
    EXPECT_EQ(back.records[i].dir, c.records[i].dir);
    EXPECT_EQ(back.records[i].bytes, c.records[i].bytes);
    EXPECT_EQ(back.records[i].note, c.records[i].note);
  }
}

TEST(Capture, EncodesTheDocumentedLines) {
  EXPECT_EQ(encode_capture_record({1234, 1900, CaptureDir::Query,
                                   {0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A}, ""}),
            "{\"t_us\":1234,\"end_us\":1900,\"dir\":\"query\",\"hex\":\"010300000001840a\"}\n");
  EXPECT_EQ(encode_capture_header(sample_header()),
            "{\"format\":\"lec6-capture\",\"version\":1,\"source\":\"sniff\","
            "\"started_utc\":\"2026-11-24T19:00:00.123456Z\",\"line\":{\"baud\":115200,"
            "\"parity\":\"N\",\"data_bits\":8,\"stop_bits\":2},\"port\":\"/dev/ttyUSB1\","
            "\"tool\":\"lec 0.1.0\"}\n");
  EXPECT_EQ(capture_dir_name(CaptureDir::Reply), "reply");
  EXPECT_EQ(capture_dir_name(CaptureDir::Noise), "noise");
  EXPECT_EQ(capture_dir_name(CaptureDir::Unknown), "unknown");
}

TEST(Capture, IgnoresUnknownKeysAndTakesDefaults) {
  const Capture c = parse_capture(
      R"({"format":"lec6-capture","version":1,"future":{"x":1}})" "\n"
      R"({"t_us":5,"end_us":6,"dir":"reply","hex":"AB","later":[1,2]})" "\n",
      "f.jsonl");
  EXPECT_EQ(c.header.line.baud, 38400u);
  EXPECT_EQ(c.header.line.parity, 'E');
  ASSERT_EQ(c.records.size(), 1u);
  EXPECT_EQ(c.records[0].bytes, Bytes{0xAB});
}

TEST(Capture, AHeaderAloneIsAnEmptyCapture) {
  EXPECT_TRUE(parse_capture(kHeader, "f").records.empty());
}

TEST(Capture, ErrorNamesFileLineAndByteOffset) {
  const std::string r1 = R"({"t_us":1,"end_us":2,"dir":"query","hex":"0103"})" "\n";
  const std::string bad = R"({"t_us":3,"end_us":4,"dir":"reply","hex":"010"})" "\n";
  const CaptureError e = error_of(kHeader + r1 + bad);
  EXPECT_EQ(e.line(), 3u);
  EXPECT_EQ(e.offset(), kHeader.size() + r1.size());
  EXPECT_EQ(std::string(e.what()),
            "capture.jsonl, line 3 (byte " + std::to_string(kHeader.size() + r1.size()) +
                "): 'hex' has an odd number of digits");
}

TEST(Capture, EachMalformedRecordIsNamed) {
  const auto problem = [](const std::string& record) {
    return std::string(error_of(kHeader + record + "\n").what());
  };
  const std::string at = "capture.jsonl, line 2 (byte " + std::to_string(kHeader.size()) + "): ";
  EXPECT_EQ(problem(R"({"t_us":1,"end_us":2,"dir":"query","hex":"01zz"})"),
            at + "'hex' has 'z' at digit 3, not a hex digit");
  EXPECT_EQ(problem(R"({"t_us":1,"end_us":2,"dir":"query","hex":""})"),
            at + "'hex' is empty (a record carries at least one byte)");
  EXPECT_EQ(problem(R"({"end_us":2,"dir":"query","hex":"01"})"), at + "'t_us' is missing");
  EXPECT_EQ(problem(R"({"t_us":-1,"end_us":2,"dir":"query","hex":"01"})"),
            at + "'t_us' is -1, outside 0..4611686018427387903");
  EXPECT_EQ(problem(R"({"t_us":1.5,"end_us":2,"dir":"query","hex":"01"})"),
            at + "'t_us' must be a whole number, not 1.5");
  EXPECT_EQ(problem(R"({"t_us":5,"end_us":2,"dir":"query","hex":"01"})"),
            at + "'end_us' (2) is before 't_us' (5)");
  EXPECT_EQ(problem(R"({"t_us":1,"end_us":2,"dir":"sideways","hex":"01"})"),
            at + "'dir' is \"sideways\"; it must be \"query\", \"reply\", \"noise\" or \"unknown\"");
  EXPECT_EQ(problem(R"({"t_us":1,"end_us":2,"dir":"query","hex":"01","note":7})"),
            at + "'note' must be a string, not 7");
  EXPECT_EQ(problem(R"([1,2])"), at + "a record must be a JSON object, not [1,2]");
  EXPECT_EQ(problem(R"({"t_us":1,"end_us":2,"dir":"query",)"), at + "not valid JSON at column 36");
}

TEST(Capture, RecordsOutOfTimeOrderAreRefused) {
  const std::string r1 = R"({"t_us":100,"end_us":200,"dir":"query","hex":"01"})" "\n";
  const std::string r2 = R"({"t_us":50,"end_us":60,"dir":"reply","hex":"01"})" "\n";
  const CaptureError e = error_of(kHeader + r1 + r2);
  EXPECT_EQ(e.line(), 3u);
  EXPECT_THAT(e.what(), HasSubstr("records out of time order: 't_us' 50 is before the previous "
                                  "record's 100"));
}

TEST(Capture, ACutLastLineIsAnError) {
  const std::string r1 = R"({"t_us":1,"end_us":2,"dir":"query","hex":"0103"})" "\n";
  const std::string cut = R"({"t_us":3,"end_us":4,"dir":"rep)";
  const CaptureError e = error_of(kHeader + r1 + cut);
  EXPECT_EQ(e.line(), 3u);
  EXPECT_EQ(e.offset(), kHeader.size() + r1.size());
  EXPECT_THAT(e.what(), HasSubstr("the file ends in the middle of this line"));
  // Cut just before the final newline, the record is whole: accepted.
  const std::string whole = R"({"t_us":3,"end_us":4,"dir":"reply","hex":"01"})";
  EXPECT_EQ(parse_capture(kHeader + r1 + whole, "f").records.size(), 2u);
}

TEST(Capture, AForeignFileIsRefusedOnItsFirstLine) {
  EXPECT_EQ(std::string(error_of("hello world\n").what()),
            "capture.jsonl, line 1 (byte 0): not valid JSON at column 1");
  EXPECT_EQ(std::string(error_of(R"({"name":"package.json"})" "\n").what()),
            "capture.jsonl, line 1 (byte 0): not a lec6 capture: the first line has no 'format'");
  EXPECT_EQ(std::string(error_of(R"({"format":"pcapng","version":1})" "\n").what()),
            "capture.jsonl, line 1 (byte 0): not a lec6 capture: 'format' is \"pcapng\", "
            "expected \"lec6-capture\"");
  EXPECT_EQ(std::string(error_of("").what()),
            "capture.jsonl, line 1 (byte 0): the file is empty (no capture header)");
  EXPECT_EQ(std::string(error_of("\n\n").what()),
            "capture.jsonl, line 1 (byte 0): the file has no capture header");
}

TEST(Capture, Version2IsRefused) {
  EXPECT_EQ(std::string(error_of(R"({"format":"lec6-capture","version":2})" "\n").what()),
            "capture.jsonl, line 1 (byte 0): version 2 is newer than this lec reads (version 1); "
            "use a newer lec");
  EXPECT_THAT(error_of(R"({"format":"lec6-capture","version":0})" "\n").what(),
              HasSubstr("'version' is 0; versions start at 1"));
  EXPECT_THAT(error_of(R"({"format":"lec6-capture"})" "\n").what(),
              HasSubstr("the header has no 'version'"));
}

TEST(Capture, BadLineSettingsAreNamed) {
  EXPECT_THAT(
      error_of(R"({"format":"lec6-capture","version":1,"line":{"parity":"X"}})" "\n").what(),
      HasSubstr("'line.parity' is \"X\"; it must be \"E\", \"O\" or \"N\""));
  EXPECT_THAT(error_of(R"({"format":"lec6-capture","version":1,"line":{"baud":0}})" "\n").what(),
              HasSubstr("'baud' is 0, outside 1..100000000"));
}

TEST(Capture, ErrorIsAnInvalidArgument) {
  try {
    parse_capture("x", "f");
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_THAT(e.what(), HasSubstr("f, line 1 (byte 0)"));
  }
}

TEST(Capture, FormatsUtcWithMicroseconds) {
  using namespace std::chrono;
  const sys_time<microseconds> t = sys_days{year{2026} / 11 / 24} + hours{19} + minutes{0} +
                                   seconds{0} + microseconds{123456};
  EXPECT_EQ(format_capture_utc(t), "2026-11-24T19:00:00.123456Z");
}

}  // namespace
}  // namespace lec6::modbus
