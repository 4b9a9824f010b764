// The RFC 4180 record reader under the step-table CSV (src/lec/csv_reader.hpp).

#include "lec/csv_reader.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::lec::csv {
namespace {

using ::testing::ElementsAre;

TEST(CsvReader, QuotedCellsHoldSeparatorsQuotesAndLineBreaks) {
  const auto r = read("a,\"b,c\",\"say \"\"hi\"\"\"\n\"two\nlines\",x\r\nlast", ",");
  ASSERT_EQ(r.size(), 3u);
  EXPECT_THAT(r[0].cells, ElementsAre("a", "b,c", "say \"hi\""));
  EXPECT_EQ(r[0].line, 1u);
  EXPECT_THAT(r[1].cells, ElementsAre("two\nlines", "x"));
  EXPECT_EQ(r[1].line, 2u);
  EXPECT_EQ(r[1].raw, "\"two\nlines\",x");
  EXPECT_THAT(r[2].cells, ElementsAre("last"));
  EXPECT_EQ(r[2].line, 4u);
  for (const auto& rec : r) EXPECT_EQ(rec.error, "");
}

TEST(CsvReader, CrLfInsideQuotesReadsAsLf) {
  const auto r = read("\"a\r\nb\"\r\n", ",");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_THAT(r[0].cells, ElementsAre("a\nb"));
}

TEST(CsvReader, BlankSpaceAroundCellsIsDroppedButNotInsideQuotes) {
  const auto r = read("  a  ;  \" b \"  ;\t3\t\n", ";");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_THAT(r[0].cells, ElementsAre("a", " b ", "3"));
}

TEST(CsvReader, TheSeparatorIsTheOneGiven) {
  EXPECT_THAT(read("1,5;2", ";")[0].cells, ElementsAre("1,5", "2"));
  EXPECT_THAT(read("1\t2 3", "\t")[0].cells, ElementsAre("1", "2 3"));
  // A quote inside an unquoted cell is just a character.
  EXPECT_THAT(read("5\",6", ",")[0].cells, ElementsAre("5\"", "6"));
}

TEST(CsvReader, EmptyLinesAndCellsAreRecordsOfEmptyCells) {
  const auto r = read("\n,,\n", ",");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_THAT(r[0].cells, ElementsAre(""));
  EXPECT_THAT(r[1].cells, ElementsAre("", "", ""));
  EXPECT_TRUE(read("", ",").empty());
}

TEST(CsvReader, TextAfterAClosingQuoteIsAnErrorAndReadingGoesOnAtTheNextLine) {
  const auto r = read("\"a\"b,c\nd,e\n", ",");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].error, "cell 1 has text after its closing quote");
  EXPECT_THAT(r[1].cells, ElementsAre("d", "e"));
  EXPECT_EQ(r[1].line, 2u);
}

TEST(CsvReader, AQuoteThatNeverClosesRunsToTheEndAndSaysWhereItOpened) {
  const auto r = read("a\nb,\"c\nd\n", ",");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[1].line, 2u);
  EXPECT_EQ(r[1].error,
            "cell 2 opens a quote (line 2) that does not close before the end of the file");
}

}  // namespace
}  // namespace lec6::lec::csv
