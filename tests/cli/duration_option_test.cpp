// One duration syntax for every time option: parsing, printing, and the old
// spellings that keep working with a hint.

#include "cli/duration_option.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace lec6::cli {
namespace {

using namespace std::chrono_literals;

TEST(Duration, ParsesANumberAndAUnit) {
  EXPECT_EQ(parse_duration("500ms").value, 500ms);
  EXPECT_EQ(parse_duration("2s").value, 2s);
  EXPECT_EQ(parse_duration("1.5s").value, 1500ms);
  EXPECT_EQ(parse_duration("250us").value, 250us);
  EXPECT_EQ(parse_duration("250\u00B5s").value, 250us);
  EXPECT_EQ(parse_duration("2min").value, 120s);
  EXPECT_EQ(parse_duration(" 30 ms ").value, 30ms);
  EXPECT_EQ(parse_duration("0.29ms").value, 290us);  // rounded, never truncated
  EXPECT_TRUE(parse_duration("2s").had_unit);
}

TEST(Duration, ABareNumberIsReportedAsSuch) {
  const DurationText t = parse_duration("5");
  EXPECT_FALSE(t.had_unit);
  EXPECT_EQ(t.number, 5.0);
}

TEST(Duration, RefusesWhatIsNotADuration) {
  for (const char* bad : {"", "ms", "5x", "5 sec", "abc", "nan", "inf", "5s5"}) {
    EXPECT_THROW(parse_duration(bad), InvalidArgument) << bad;
  }
  try {
    parse_duration("5x");
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("500ms"), std::string::npos) << e.what();
  }
}

TEST(Duration, PrintsTheShortestExactSpelling) {
  EXPECT_EQ(format_duration(0s), "0s");
  EXPECT_EQ(format_duration(60s), "60s");
  EXPECT_EQ(format_duration(1500ms), "1.5s");
  EXPECT_EQ(format_duration(50ms), "50ms");
  EXPECT_EQ(format_duration(250us), "250us");
  EXPECT_EQ(format_duration(1500us), "1.5ms");
  EXPECT_EQ(format_duration(7ns), "7ns");
  for (Duration d : {Duration(0s), Duration(60s), Duration(1500ms), Duration(50ms), Duration(250us),
                     Duration(1500us), Duration(1234567us)}) {
    EXPECT_EQ(parse_duration(format_duration(d)).value, d) << format_duration(d);
  }
}

struct Parsed {
  std::string error;
  std::string warnings;
};

Parsed parse(CLI::App& app, std::vector<std::string> args) {
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  Parsed p;
  ::testing::internal::CaptureStderr();
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    p.error = e.what();
  }
  p.warnings = ::testing::internal::GetCapturedStderr();
  return p;
}

const DurationLimits kUpToAMinute{0s, 60s};

TEST(DurationOption, TakesAUnitAndChecksTheRange) {
  CLI::App app;
  Duration d = 10s;
  add_duration_option(&app, "--timeout", d, "deadline", kUpToAMinute);
  auto p = parse(app, {"--timeout", "500ms"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(p.warnings, "");
  EXPECT_EQ(d, 500ms);

  CLI::App app2;
  Duration d2 = 10s;
  add_duration_option(&app2, "--timeout", d2, "deadline", kUpToAMinute);
  p = parse(app2, {"--timeout", "2min"});
  EXPECT_NE(p.error.find("--timeout"), std::string::npos) << p.error;
  EXPECT_NE(p.error.find("0s to 60s"), std::string::npos) << p.error;
  EXPECT_EQ(d2, 10s);  // nothing applied
}

TEST(DurationOption, ShowsTheDefaultInHelp) {
  CLI::App app;
  Duration d = 60s;
  add_duration_option(&app, "--timeout", d, "deadline", kUpToAMinute);
  const std::string help = app.help();
  EXPECT_NE(help.find("--timeout DURATION=60s"), std::string::npos) << help;
}

TEST(DurationOption, ABareNumberIsRefusedWhereTheOptionIsNew) {
  CLI::App app;
  Duration d = 10s;
  add_duration_option(&app, "--timeout", d, "deadline", kUpToAMinute);
  const auto p = parse(app, {"--timeout", "5"});
  EXPECT_NE(p.error.find("needs a unit"), std::string::npos) << p.error;
  EXPECT_EQ(d, 10s);
}

TEST(DurationOption, ABareNumberKeepsItsOldUnitWithAHint) {
  CLI::App app;
  Duration d{};
  add_duration_option(&app, "-i,--interval", d, "pause", kUpToAMinute, BareNumber::Seconds);
  const auto p = parse(app, {"-i", "0.2"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(d, 200ms);
  EXPECT_NE(p.warnings.find("deprecated"), std::string::npos) << p.warnings;
  EXPECT_NE(p.warnings.find("write --interval 0.2s"), std::string::npos) << p.warnings;
}

TEST(DurationOption, ABareZeroNeedsNoUnit) {
  CLI::App app;
  Duration d = 1s;
  add_duration_option(&app, "--interval", d, "pause", kUpToAMinute, BareNumber::Milliseconds);
  const auto p = parse(app, {"--interval", "0"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(p.warnings, "");
  EXPECT_EQ(d, 0s);
}

TEST(DurationOption, AResolutionRefusesFractions) {
  CLI::App app;
  Duration d{};
  add_duration_option(&app, "--rs485-delay-before", d, "delay", {0s, 1s, 1ms});
  const auto p = parse(app, {"--rs485-delay-before", "1500us"});
  EXPECT_NE(p.error.find("whole multiple of 1ms"), std::string::npos) << p.error;
}

TEST(RenamedOption, TheOldNameSetsTheNewValueWithAHint) {
  CLI::App app;
  Duration d = 60s;
  add_deadline_option(&app, d, "deadline");
  const auto p = parse(app, {"--timeout-s", "2.5"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(d, 2500ms);
  EXPECT_NE(p.warnings.find("--timeout-s 2.5 is deprecated"), std::string::npos) << p.warnings;
  EXPECT_NE(p.warnings.find("write --timeout 2.5s"), std::string::npos) << p.warnings;
}

TEST(RenamedOption, IsHiddenFromHelp) {
  CLI::App app;
  Duration d = 60s;
  add_deadline_option(&app, d, "deadline");
  const std::string help = app.help();
  EXPECT_NE(help.find("--timeout DURATION"), std::string::npos) << help;
  EXPECT_EQ(help.find("--timeout-s"), std::string::npos) << help;
}

TEST(RenamedOption, ChecksTheRangeBeforeWarningAndAppliesNothing) {
  CLI::App app;
  Duration d = 50ms;
  add_renamed_duration_option(&app, "--delay-ms", "--td", d, BareNumber::Milliseconds, {0s, 1s});
  const auto p = parse(app, {"--delay-ms", "-1"});
  EXPECT_NE(p.error.find("--delay-ms"), std::string::npos) << p.error;
  EXPECT_NE(p.error.find("-1ms is out of range: 0s to 1s"), std::string::npos) << p.error;
  EXPECT_EQ(p.warnings, "");
  EXPECT_EQ(d, 50ms);
}

TEST(RenamedOption, AUnitGivenToTheOldNameIsHonoured) {
  CLI::App app;
  Duration d{};
  add_renamed_duration_option(&app, "--timeout", "--reply-margin", d, BareNumber::Milliseconds,
                              kUpToAMinute);
  const auto p = parse(app, {"--timeout", "1s"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(d, 1s);
  EXPECT_NE(p.warnings.find("write --reply-margin 1s"), std::string::npos) << p.warnings;
}

}  // namespace
}  // namespace lec6::cli
