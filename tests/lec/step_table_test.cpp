// Step tables: CSV and JSON formats, every field's range and every file error.
// Over 450 lines: one case per format rule and error message, kept together.

#include "lec6/lec/step_table.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

namespace lec6::lec {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr int32_t kI32 = 2147483647;

std::string read_fixture(const std::string& name) {
  const std::string path = std::string(LEC6_TEST_DATA_DIR) + "/steps/" + name;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << "cannot open " << path;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string joined_table_errors(const TableErrors& errors) {
  std::string out;
  for (const auto& e : errors) out += e + "\n";
  return out;
}

const std::string kHeader =
    "step,mode,speed_mm_s,position_mm,accel_mm_s2,decel_mm_s2,pushing_force_pct,"
    "trigger_level_pct,pushing_speed_mm_s,moving_force_pct,area1_mm,area2_mm,in_position_mm";

StepData abs_step(int32_t position_001mm) {
  return StepData{
      MovementMode::Absolute, 500, position_001mm, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};
}

StepData random_valid_step(std::mt19937& rng) {
  auto in = [&](int64_t lo, int64_t hi) {
    return std::uniform_int_distribution<int64_t>(lo, hi)(rng);
  };
  if (in(0, 4) == 0) return StepData{};  // blank
  StepData s;
  s.movement_mode = in(0, 1) ? MovementMode::Absolute : MovementMode::Incremental;
  s.speed_mm_s = static_cast<uint16_t>(in(1, 65535));
  s.position_001mm = static_cast<int32_t>(in(-kI32, kI32));
  s.acceleration_mm_s2 = static_cast<uint16_t>(in(1, 65535));
  s.deceleration_mm_s2 = static_cast<uint16_t>(in(1, 65535));
  s.pushing_force_pct = static_cast<uint16_t>(in(0, 1) ? 0 : in(1, 100));
  s.trigger_level_pct =
      static_cast<uint16_t>(s.pushing_force_pct ? in(0, s.pushing_force_pct) : in(0, 100));
  s.pushing_speed_mm_s = static_cast<uint16_t>(in(1, 65535));
  s.moving_force_pct = static_cast<uint16_t>(in(0, 300));
  // Small values too, so -0.05 style lengths are exercised.
  s.area1_001mm = static_cast<int32_t>(in(0, 1) ? in(-kI32, kI32) : in(-200, 200));
  s.area2_001mm = static_cast<int32_t>(in(-kI32, kI32));
  s.in_position_001mm = static_cast<int32_t>(in(0, 1) ? in(1, kI32) : in(1, 150));
  EXPECT_TRUE(validate(s).empty());
  return s;
}

StepTable random_table(std::mt19937& rng, bool partial) {
  StepTable t;
  for (auto& s : t.steps) s = random_valid_step(rng);
  if (partial) {
    t.covered.reset();
    for (std::size_t i = 0; i < StepTable::kSteps; ++i) {
      if (rng() % 3 == 0) t.covered.set(i);
    }
    t.covered.set(rng() % StepTable::kSteps);
    // Steps a table does not cover hold nothing.
    for (std::size_t i = 0; i < StepTable::kSteps; ++i) {
      if (!t.covered.test(i)) t.steps[i] = StepData{};
    }
  }
  // Printable ASCII including the characters CSV and JSON must escape.
  const std::string alphabet = "ABCxyz09 -_,;\"'\\#:";
  const std::size_t len = rng() % 15;
  for (std::size_t i = 0; i < len; ++i) t.equipment_name += alphabet[rng() % alphabet.size()];
  while (!t.equipment_name.empty() && t.equipment_name.back() == ' ') t.equipment_name.pop_back();
  while (!t.equipment_name.empty() && t.equipment_name.front() == ' ') t.equipment_name.erase(0, 1);
  t.controller_id = static_cast<uint8_t>(rng());
  return t;
}

// ---------------------------------------------------------------- writing

TEST(StepTableCsv, WritesCommentsHeaderAndOneRowPerStep) {
  StepTable t;
  t.equipment_name = "AXIS1";
  t.controller_id = 1;
  t.steps[0] =
      StepData{MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100, -150, 0, 100};
  t.steps[1] = StepData{MovementMode::Incremental, 50, -1, 1000, 1000, 70, 60, 10, 100, 0, 0, 500};
  const std::string csv = to_csv(t);
  std::vector<std::string> lines;
  std::istringstream in(csv);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_EQ(lines.size(), 2u + 1u + 64u);
  EXPECT_EQ(lines[0], "# equipment_name: AXIS1");
  EXPECT_EQ(lines[1], "# controller_id: 1");
  EXPECT_EQ(lines[2], kHeader);
  EXPECT_EQ(lines[3], "0,abs,500,150.00,5000,5000,0,0,20,100,-1.50,0.00,1.00");
  EXPECT_EQ(lines[4], "1,inc,50,-0.01,1000,1000,70,60,10,100,0.00,0.00,5.00");
  EXPECT_EQ(lines[5], "2,0,0,0.00,0,0,0,0,0,0,0.00,0.00,0.00");
  EXPECT_EQ(lines[66], "63,0,0,0.00,0,0,0,0,0,0,0.00,0.00,0.00");
  EXPECT_EQ(csv.find('\r'), std::string::npos);
  EXPECT_EQ(csv.back(), '\n');
}

TEST(StepTableCsv, QuotesTheNameLineWhenItHoldsASeparatorOrQuote) {
  StepTable t;
  t.equipment_name = "A,\"B\"";
  const std::string csv = to_csv(t);
  EXPECT_TRUE(csv.starts_with("\"# equipment_name: A,\"\"B\"\"\"\n")) << csv;
  auto back = parse_csv(csv);
  ASSERT_TRUE(back) << joined_table_errors(back.error());
  EXPECT_EQ(back->equipment_name, "A,\"B\"");
}

TEST(StepTableCsv, PartialTableWritesOnlyCoveredSteps) {
  StepTable t;
  t.covered.reset();
  t.covered.set(5);
  t.covered.set(9);
  t.steps[5] = abs_step(100);
  const std::string csv = to_csv(t);
  EXPECT_THAT(csv, HasSubstr("\n5,abs,500,1.00,"));
  EXPECT_THAT(csv, HasSubstr("\n9,0,0,0.00,"));
  EXPECT_EQ(csv.find("\n0,"), std::string::npos);
}

// ---------------------------------------------------------------- round trips

TEST(StepTableCsv, RoundTripsRandomTablesExactly) {
  std::mt19937 rng(6);
  for (int n = 0; n < 300; ++n) {
    const StepTable t = random_table(rng, n % 3 == 0);
    const std::string csv = to_csv(t);
    auto back = parse_csv(csv);
    ASSERT_TRUE(back) << joined_table_errors(back.error()) << csv;
    ASSERT_EQ(*back, t) << csv;
    ASSERT_EQ(to_csv(*back), csv);
  }
}

TEST(StepTableJson, RoundTripsRandomTablesExactly) {
  std::mt19937 rng(7);
  for (int n = 0; n < 150; ++n) {
    const StepTable t = random_table(rng, n % 3 == 0);
    const std::string text = to_json(t);
    auto back = parse_json(text);
    ASSERT_TRUE(back) << joined_table_errors(back.error()) << text;
    ASSERT_EQ(*back, t) << text;
    ASSERT_EQ(to_json(*back), text);
  }
}

TEST(StepTableCsv, RoundTripsExtremeLengths) {
  StepTable t;
  t.steps[0] = abs_step(-kI32);
  t.steps[0].area1_001mm = kI32;
  t.steps[0].area2_001mm = -1;
  t.steps[0].in_position_001mm = kI32;
  t.steps[1] = abs_step(kI32);
  t.steps[1].area1_001mm = -kI32;
  for (auto fmt : {TableFormat::Csv, TableFormat::Json}) {
    auto back = parse_table(format_table(t, fmt), fmt);
    ASSERT_TRUE(back) << joined_table_errors(back.error());
    EXPECT_EQ(*back, t);
  }
  EXPECT_THAT(to_csv(t), HasSubstr("0,abs,500,-21474836.47,5000,5000,0,0,20,100,21474836.47,-0.01,"
                                   "21474836.47\n"));
}

TEST(StepTableFormat, ChosenByExtension) {
  EXPECT_EQ(table_format_for_path("backup.json"), TableFormat::Json);
  EXPECT_EQ(table_format_for_path("/tmp/BACKUP.JSON"), TableFormat::Json);
  EXPECT_EQ(table_format_for_path("backup.csv"), TableFormat::Csv);
  EXPECT_EQ(table_format_for_path("backup.json.txt"), TableFormat::Csv);
  EXPECT_EQ(table_format_for_path("backup"), TableFormat::Csv);
  EXPECT_EQ(table_format_for_path("json"), TableFormat::Csv);
}

// ---------------------------------------------------------------- fixtures

TEST(StepTableCsv, ReadsASpreadsheetSavedFile) {
  const std::string text = read_fixture("spreadsheet_saved.csv");
  // The fixture must really be what a spreadsheet writes (a checkout that
  // normalises line ends would make this test prove nothing).
  ASSERT_TRUE(text.starts_with("\xEF\xBB\xBF"));
  ASSERT_NE(text.find("\r\n"), std::string::npos);
  auto t = parse_csv(text);
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_EQ(t->equipment_name, "AX \"B\", 1");
  EXPECT_EQ(t->controller_id, 7);
  EXPECT_EQ(t->covered_steps(), (std::vector<unsigned>{0, 1, 2, 3}));
  EXPECT_EQ(t->steps[0], abs_step(15000));
  EXPECT_EQ(t->steps[1], (StepData{MovementMode::Incremental, 1000, -1250, 3000, 3000, 0, 0, 20,
                                   150, -500, 500, 50}));
  EXPECT_TRUE(t->steps[2].is_blank());
  EXPECT_EQ(t->steps[3], (StepData{MovementMode::Absolute, 50, 2025, 1000, 1000, 70, 60, 10, 100,
                                   1000, 3000, 500}));
}

TEST(StepTableCsv, ReadsSemicolonsAndDecimalCommas) {
  auto t = parse_csv(read_fixture("semicolon_decimal_comma.csv"));
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_EQ(t->equipment_name, "Press 2");
  EXPECT_EQ(t->controller_id, 3);
  EXPECT_EQ(t->covered_steps(), (std::vector<unsigned>{0, 5, 63}));
  EXPECT_EQ(t->steps[0], abs_step(15000));
  EXPECT_EQ(t->steps[5], (StepData{MovementMode::Incremental, 100, -1250, 3000, 3000, 0, 0, 20, 100,
                                   -125, 200, 5}));
  EXPECT_TRUE(t->steps[63].is_blank());
}

TEST(StepTableJson, FixtureReadsLikeTheSameCsv) {
  auto json = parse_json(read_fixture("press2.json"));
  ASSERT_TRUE(json) << joined_table_errors(json.error());
  auto csv = parse_csv(read_fixture("semicolon_decimal_comma.csv"));
  ASSERT_TRUE(csv) << joined_table_errors(csv.error());
  EXPECT_EQ(*json, *csv);
  EXPECT_EQ(
      parse_table(read_fixture("press2.json"), table_format_for_path("press2.json"))->steps[5],
      csv->steps[5]);
}

TEST(StepTableCsv, BadRowNamesLineStepFieldAndRangeAndReturnsNoTable) {
  auto t = parse_csv(read_fixture("bad_row.csv"));
  ASSERT_FALSE(t);
  ASSERT_EQ(t.error().size(), 1u) << joined_table_errors(t.error());
  EXPECT_EQ(t.error()[0],
            "line 5 (step 3): speed_mm_s 70000 mm/s is out of range: allowed 1 to 65535 mm/s");
}

TEST(StepTableCsv, ReadsReorderedCapitalisedAndLongNamedColumns) {
  auto t = parse_csv(read_fixture("reordered_columns.csv"));
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_EQ(t->covered_steps(), (std::vector<unsigned>{7, 10}));
  EXPECT_EQ(t->equipment_name, "");
  EXPECT_EQ(t->controller_id, 0);
  EXPECT_EQ(t->steps[10], (StepData{MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100,
                                    -1000, 1000, 100}));
  EXPECT_EQ(t->steps[7], (StepData{MovementMode::Incremental, 80, -325, 2000, 1500, 50, 40, 15, 120,
                                   0, 0, 250}));
}

TEST(StepTableCsv, UnknownColumnIsNamed) {
  auto t = parse_csv(read_fixture("unknown_column.csv"));
  ASSERT_FALSE(t);
  ASSERT_EQ(t.error().size(), 1u) << joined_table_errors(t.error());
  EXPECT_THAT(t.error()[0], AllOf(HasSubstr("line 1: unknown columns 'colour', 'Notes'"),
                                  HasSubstr("known columns are step, mode, speed_mm_s")));
}

TEST(StepTableCsv, DuplicateStepIsRefused) {
  auto t = parse_csv(read_fixture("duplicate_step.csv"));
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error(), ElementsAre("line 6: step 2 repeats line 4"));
}

// ---------------------------------------------------------------- CSV errors

TEST(StepTableCsv, ReportsEveryErrorOfEveryRow) {
  const std::string text = kHeader + "\n" +
                           "0,abs,500,150.001,5000,0,0,0,20,100,0.00,0.00,1.00\n" +      // line 2
                           "1,abs,500,150.00,5000,5000,50,80,20,100,0.00,0.00,1.00\n" +  // 3
                           "64,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n" +   // 4
                           "2,fly,500,x,5000,5000,0,0,20,301,0.00,0.00,0\n" +            // 5
                           "3,0,500,0,0,0,0,0,0,0,0,0,0\n" +                             // 6
                           "4,abs,500,,5000,5000,0,0,20,100,0.00,0.00\n";                // 7
  auto t = parse_csv(text);
  ASSERT_FALSE(t);
  EXPECT_THAT(
      t.error(),
      ElementsAre(
          "line 2 (step 0): position_mm: '150.001' has more than two decimals: lengths are in "
          "0.01 mm steps",
          "line 2 (step 0): decel_mm_s2 0 mm/s² is out of range: allowed 1 to 65535 mm/s²",
          "line 3 (step 1): trigger level 80 % exceeds pushing force 50 %",
          "line 4: step 64 is out of range: allowed 0 to 63",
          "line 5 (step 2): mode 'fly': expected abs or inc",
          "line 5 (step 2): position_mm: 'x' is not a length in mm (e.g. 150.00)",
          "line 5 (step 2): moving_force_pct 301 % is out of range: allowed 0 to 300 %",
          "line 6 (step 3): mode '0': expected abs or inc (mode 0 is only for a blank step: a row "
          "of all zeros)",
          "line 6 (step 3): accel_mm_s2 0 mm/s² is out of range: allowed 1 to 65535 mm/s²",
          "line 6 (step 3): decel_mm_s2 0 mm/s² is out of range: allowed 1 to 65535 mm/s²",
          "line 6 (step 3): pushing_speed_mm_s 0 mm/s is out of range: allowed 1 to 65535 mm/s",
          "line 7 (step 4): position_mm is empty", "line 7 (step 4): in_position_mm is empty"));
}

TEST(StepTableCsv, ErrorsUseTheColumnNameTheFileUses) {
  auto t = parse_csv(
      "Step,Mode,Speed,position,accel,decel,push,trigger,push-speed,moving-force,"
      "area1,area2,inp\n0,abs,0,1,1,1,0,0,1,0,0,0,1\n");
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error(), ElementsAre("line 2 (step 0): Speed 0 mm/s is out of range: allowed 1 to "
                                     "65535 mm/s"));
}

TEST(StepTableCsv, BlankRowMayUseBlankWordAndUnpaddedZeros) {
  auto t = parse_csv(kHeader + "\n7,blank,0,0,0,0,0,0,0,0,0,-0,0.0\n");
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_TRUE(t->steps[7].is_blank());
  EXPECT_EQ(t->covered_steps(), std::vector<unsigned>{7});
}

TEST(StepTableCsv, MissingAndRepeatedColumnsAreErrors) {
  auto t = parse_csv("step,mode,speed,speed_mm_s,position_mm\n0,abs,1,1,1\n");
  ASSERT_FALSE(t);
  ASSERT_EQ(t.error().size(), 2u) << joined_table_errors(t.error());
  EXPECT_EQ(t.error()[0], "line 1: columns 'speed' and 'speed_mm_s' are both speed_mm_s");
  EXPECT_EQ(t.error()[1],
            "line 1: missing columns accel_mm_s2, decel_mm_s2, pushing_force_pct, "
            "trigger_level_pct, pushing_speed_mm_s, moving_force_pct, area1_mm, area2_mm, "
            "in_position_mm");

  auto no_step = parse_csv("mode,speed\nabs,1\n");
  ASSERT_FALSE(no_step);
  EXPECT_THAT(no_step.error()[0], HasSubstr("missing columns step, position_mm"));
}

TEST(StepTableCsv, HeaderOnlyOrEmptyFilesAreErrors) {
  auto header_only = parse_csv("# controller_id: 1\n" + kHeader + "\n\n");
  ASSERT_FALSE(header_only);
  EXPECT_THAT(header_only.error(), ElementsAre("the file has no step rows"));

  auto empty = parse_csv("\xEF\xBB\xBF\r\n\r\n");
  ASSERT_FALSE(empty);
  EXPECT_THAT(empty.error()[0], HasSubstr("no header line"));
}

TEST(StepTableCsv, RefusesUtf16) {
  auto t = parse_csv(std::string("\xFF\xFEs\0t\0", 6));
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error()[0], HasSubstr("UTF-16"));
}

TEST(StepTableCsv, QuotingErrorsAndStrayCellsAreReported) {
  // A quoted cell may span lines (RFC 4180), so a quote that never closes
  // runs to the end of the file; it is reported on the line it opened.
  const std::string text = kHeader + "\n" +
                           "1,abs,\"500\"x,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n" +
                           "2,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00,,,9\n" +
                           "3,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00,,\n" +
                           "4,abs,\"500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n" +
                           "5,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n";
  auto t = parse_csv(text);
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error(),
              ElementsAre("line 2: cell 3 has text after its closing quote",
                          "line 3 (step 2): cell 16 ('9') is past the header's 13 columns",
                          "line 5: cell 3 opens a quote (line 5) that does not close before the "
                          "end of the file"));
}

TEST(StepTableCsv, AQuotedLineBreakInACommentIsPartOfTheComment) {
  // As a spreadsheet saves a note typed over two lines in cell A1, with a
  // separator in it: one quoted cell across two lines.
  const std::string text =
      "\"# note: backup before the new fixture,\nchecked by J.\"\n"
      "# equipment_name: AXIS-1\n" +
      kHeader + "\n" +
      "0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n"
      "\"# note: a second\r\nmultiline comment\",,\n"
      "1,abs,600,160.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n";
  auto t = parse_csv(text);
  ASSERT_TRUE(t) << testing::PrintToString(t.error());
  EXPECT_EQ(t->equipment_name, "AXIS-1");
  EXPECT_TRUE(t->covers(0));
  EXPECT_TRUE(t->covers(1));
  EXPECT_EQ(t->steps[1].speed_mm_s, 600);
}

TEST(StepTableCsv, ErrorsAfterAQuotedLineBreakNameTheRightLine) {
  const std::string text = "\"# note: two\nlines\"\n" + kHeader + "\n" +
                           "0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n" +
                           "1,abs,500,x,5000,5000,0,0,20,100,0.00,0.00,1.00\n";
  auto t = parse_csv(text);
  ASSERT_FALSE(t);
  ASSERT_EQ(t.error().size(), 1u);
  EXPECT_THAT(t.error()[0], testing::StartsWith("line 5 (step 1): position"));
}

TEST(StepTableCsv, AnEquipmentNameWithALineBreakIsRefused) {
  const std::string text = "\"# equipment_name: AXIS\n1\"\n" + kHeader + "\n" +
                           "0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n";
  auto t = parse_csv(text);
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error()[0], testing::StartsWith("line 1: "));
}

TEST(StepTableCsv, CrLfAndBomAndTabSeparatorsInMemory) {
  std::string text = "\xEF\xBB\xBF# equipment_name: X\r\n" + kHeader + "\r\n" +
                     "0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\r\n";
  auto t = parse_csv(text);
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_EQ(t->steps[0], abs_step(15000));
  EXPECT_EQ(t->equipment_name, "X");

  std::string tabs = kHeader + "\n0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n";
  for (char& c : tabs) {
    if (c == ',') c = '\t';
  }
  auto tt = parse_csv(tabs);
  ASSERT_TRUE(tt) << joined_table_errors(tt.error());
  EXPECT_EQ(tt->steps[0], abs_step(15000));
}

TEST(StepTableCsv, MetadataIsValidated) {
  auto t = parse_csv(
      "# equipment_name: FIFTEEN-CHARS-X\n# controller_id: 256\n"
      "# controller_id: 2\n# a free comment: ignored\n" +
      kHeader + "\n0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00\n");
  ASSERT_FALSE(t);
  ASSERT_EQ(t.error().size(), 3u) << joined_table_errors(t.error());
  EXPECT_THAT(t.error()[0],
              HasSubstr("line 1: equipment name 'FIFTEEN-CHARS-X' has 15 characters"));
  EXPECT_THAT(t.error()[1], HasSubstr("line 2: controller_id '256' is not a controller ID"));
  EXPECT_EQ(t.error()[2], "line 3: controller_id is given again (first on line 2)");
}

TEST(StepTableCsv, MangledFilesNeverCrashAndNeverHalfParse) {
  std::mt19937 rng(11);
  const std::string base = to_csv(random_table(rng, true));
  const std::string junk = ",;\"\r\n\t #:.-0123456789abcinxyz\xEF\xBB\xBF";
  for (int n = 0; n < 2000; ++n) {
    std::string text = base;
    for (int k = 0; k < 1 + n % 4; ++k) {
      const std::size_t at = rng() % text.size();
      switch (rng() % 3) {
        case 0:
          text[at] = junk[rng() % junk.size()];
          break;
        case 1:
          text.erase(at, 1 + rng() % 3);
          break;
        default:
          text.insert(at, 1, junk[rng() % junk.size()]);
          break;
      }
      if (text.empty()) text = "x";
    }
    auto t = parse_csv(text);
    if (t) {
      // Whatever was accepted is a valid table that writes and reads back.
      for (unsigned s : t->covered_steps()) {
        ASSERT_TRUE(t->steps[s].is_blank() || validate(t->steps[s]).empty()) << text;
      }
      auto again = parse_csv(to_csv(*t));
      ASSERT_TRUE(again) << text;
      ASSERT_EQ(*again, *t);
    } else {
      ASSERT_FALSE(t.error().empty());
    }
  }
}

// ---------------------------------------------------------------- JSON

TEST(StepTableJson, WritesOneStepPerLine) {
  StepTable t;
  t.covered.reset();
  t.covered.set(0);
  t.covered.set(1);
  t.equipment_name = "AX\"1";
  t.controller_id = 2;
  t.steps[0] = abs_step(-15000);
  EXPECT_EQ(to_json(t),
            "{\n"
            "  \"equipment_name\": \"AX\\\"1\",\n"
            "  \"controller_id\": 2,\n"
            "  \"steps\": [\n"
            "    {\"step\": 0, \"mode\": \"abs\", \"speed_mm_s\": 500, \"position_mm\": -150.00, "
            "\"accel_mm_s2\": 5000, \"decel_mm_s2\": 5000, \"pushing_force_pct\": 0, "
            "\"trigger_level_pct\": 0, \"pushing_speed_mm_s\": 20, \"moving_force_pct\": 100, "
            "\"area1_mm\": 0.00, \"area2_mm\": 0.00, \"in_position_mm\": 1.00},\n"
            "    {\"step\": 1, \"mode\": \"blank\", \"speed_mm_s\": 0, \"position_mm\": 0.00, "
            "\"accel_mm_s2\": 0, \"decel_mm_s2\": 0, \"pushing_force_pct\": 0, "
            "\"trigger_level_pct\": 0, \"pushing_speed_mm_s\": 0, \"moving_force_pct\": 0, "
            "\"area1_mm\": 0.00, \"area2_mm\": 0.00, \"in_position_mm\": 0.00}\n"
            "  ]\n"
            "}\n");
}

TEST(StepTableJson, AcceptsStringsLongNamesAndWholeNumbersAsFloats) {
  auto t = parse_json(R"({"steps": [{"Step": "4", "movement_mode": "INC", "speed": 500.0,
      "position": "-1.5", "acceleration": 5000, "deceleration": 5000, "pushing_force": 0,
      "trigger_level": 0, "pushing_speed": 20, "moving_force": 100, "area1": 0,
      "area2": 150.07, "in_position": 1}]})");
  ASSERT_TRUE(t) << joined_table_errors(t.error());
  EXPECT_EQ(t->covered_steps(), std::vector<unsigned>{4});
  EXPECT_EQ(t->steps[4], (StepData{MovementMode::Incremental, 500, -150, 5000, 5000, 0, 0, 20, 100,
                                   0, 15007, 100}));
}

TEST(StepTableJson, ReportsEveryErrorWithItsPlace) {
  auto t = parse_json(R"({"equipment_name": "A", "colour": 1, "steps": [
      {"step": 0, "mode": "abs", "speed_mm_s": 70000, "position_mm": 150.005, "accel_mm_s2": 1,
       "decel_mm_s2": 1, "pushing_force_pct": 50, "trigger_level_pct": 60, "pushing_speed_mm_s": 1,
       "moving_force_pct": 0, "area1_mm": 0, "area2_mm": 0, "in_position_mm": 1},
      {"step": 0, "mode": 0, "speed_mm_s": 0, "position_mm": 0, "accel_mm_s2": 0,
       "decel_mm_s2": 0, "pushing_force_pct": 0, "trigger_level_pct": 0, "pushing_speed_mm_s": 0,
       "moving_force_pct": 0, "area1_mm": 0, "area2_mm": 0, "in_position_mm": 0},
      {"step": 1, "mode": "abs", "speed_mm_s": null, "position_mm": 1, "nope": 1},
      [1]
    ]})");
  ASSERT_FALSE(t);
  EXPECT_THAT(
      t.error(),
      ElementsAre(
          "unknown key 'colour': known keys are equipment_name, controller_id, steps",
          "steps[0] (step 0): speed_mm_s 70000 mm/s is out of range: allowed 1 to 65535 mm/s",
          "steps[0] (step 0): position_mm: '150.005' has more than two decimals: lengths are in "
          "0.01 mm steps",
          "steps[1]: step 0 repeats steps[0]",
          "steps[2] (step 1): speed_mm_s must be a number or a string, not null",
          "steps[2] (step 1): unknown key 'nope': known keys are step, mode, speed_mm_s, "
          "position_mm, accel_mm_s2, decel_mm_s2, pushing_force_pct, trigger_level_pct, "
          "pushing_speed_mm_s, moving_force_pct, area1_mm, area2_mm, in_position_mm (or the "
          "fields' CLI or manual names)",
          "steps[2] (step 1): missing keys accel_mm_s2, decel_mm_s2, pushing_force_pct, "
          "trigger_level_pct, pushing_speed_mm_s, moving_force_pct, area1_mm, area2_mm, "
          "in_position_mm",
          "steps[3]: must be an object"));
}

TEST(StepTableJson, CrossFieldRuleNamesTheStep) {
  auto t = parse_json(R"({"steps": [{"step": 9, "mode": "abs", "speed_mm_s": 1, "position_mm": 0,
      "accel_mm_s2": 1, "decel_mm_s2": 1, "pushing_force_pct": 50, "trigger_level_pct": 60,
      "pushing_speed_mm_s": 1, "moving_force_pct": 0, "area1_mm": 0, "area2_mm": 0,
      "in_position_mm": 1}]})");
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error(),
              ElementsAre("steps[0] (step 9): trigger level 60 % exceeds pushing force 50 %"));
}

TEST(StepTableJson, SyntaxErrorsRepeatedKeysAndWrongShapes) {
  auto bad = parse_json("{\"steps\": [}");
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.error()[0], HasSubstr("not valid JSON"));

  auto twice = parse_json(R"({"controller_id": 1, "controller_id": 2, "steps": []})");
  ASSERT_FALSE(twice);
  EXPECT_THAT(twice.error(), ElementsAre("key 'controller_id' appears twice in one object"));

  auto array = parse_json("[]");
  ASSERT_FALSE(array);
  EXPECT_THAT(array.error()[0], HasSubstr("must be an object"));

  auto no_steps = parse_json(R"({"controller_id": 1})");
  ASSERT_FALSE(no_steps);
  EXPECT_THAT(no_steps.error(), ElementsAre("\"steps\" must be an array of step objects"));

  auto empty = parse_json(R"({"steps": []})");
  ASSERT_FALSE(empty);
  EXPECT_THAT(empty.error(), ElementsAre("\"steps\" is empty: no step to restore"));
}

// ---------------------------------------------------------------- diff

TEST(StepTableDiff, ListsDifferingFieldsOfStepsBothCover) {
  StepTable a, b;
  a.steps[3] = abs_step(15000);
  b.steps[3] = abs_step(-2000);
  b.steps[3].speed_mm_s = 600;
  a.steps[4] = abs_step(100);  // b's step 4 is blank
  a.steps[10] = abs_step(1);   // b does not cover step 10
  b.covered.reset(10);
  const auto d = diff(a, b);
  // Step 4: all but push, trigger, area1 and area2 (0 in both).
  ASSERT_EQ(d.size(), 2u + kStepFieldCount - 4u);
  EXPECT_EQ(d[0], (StepFieldDiff{3, StepField::Speed, "500", "600"}));
  EXPECT_EQ(d[1], (StepFieldDiff{3, StepField::Position, "150.00", "-20.00"}));
  EXPECT_EQ(d[2], (StepFieldDiff{4, StepField::MovementMode, "abs", "blank"}));
  EXPECT_EQ(d.back(), (StepFieldDiff{4, StepField::InPosition, "1.00", "0.00"}));
  for (const auto& x : d) EXPECT_NE(x.step, 10u);

  EXPECT_TRUE(diff(a, a).empty());
}

TEST(StepTableDiff, SideBySideText) {
  const std::vector<StepFieldDiff> d{{3, StepField::Speed, "500", "600"},
                                     {12, StepField::Acceleration, "5000", "3000"},
                                     {12, StepField::MovementMode, "abs", "inc"}};
  EXPECT_EQ(format_diff_side_by_side(d, "device", "backup.csv"),
            "step  field          device  backup.csv\n"
            "   3  speed (mm/s)   500     600\n"
            "  12  accel (mm/s²)  5000    3000\n"
            "  12  mode           abs     inc\n");
  EXPECT_EQ(format_diff_side_by_side({}, "a", "b"), "no differences\n");
}

TEST(RegistersThatDiffer, SmallestRangeCoveringEveryDifference) {
  const StepData have = abs_step(15000);
  EXPECT_EQ(registers_that_differ(have, have), std::nullopt);

  StepData want = have;
  want.speed_mm_s = 600;
  EXPECT_EQ(registers_that_differ(have, want), (RegisterRange{1, 1}));

  want = have;
  want.position_001mm = 15001;  // low word only
  EXPECT_EQ(registers_that_differ(have, want), (RegisterRange{3, 3}));

  want = have;
  want.position_001mm = -15000;  // both words
  EXPECT_EQ(registers_that_differ(have, want), (RegisterRange{2, 3}));

  want = have;
  want.speed_mm_s = 1;
  want.in_position_001mm = 101;  // offset F
  const auto r = registers_that_differ(have, want);
  ASSERT_TRUE(r);
  EXPECT_EQ(*r, (RegisterRange{1, 15}));
  EXPECT_EQ(r->count(), 15u);

  EXPECT_EQ(registers_that_differ(StepData{}, have), (RegisterRange{0, 15}));
  EXPECT_EQ(registers_that_differ(have, StepData{}), (RegisterRange{0, 15}));
}

}  // namespace
}  // namespace lec6::lec
