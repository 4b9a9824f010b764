// Teach-in (include/lec6/cycle/teach.hpp): a point written into the file's
// text, everything else kept byte for byte.

#include "lec6/cycle/teach.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/cycle/cycle_file.hpp"

namespace lec6::cycle {
namespace {

using ::testing::HasSubstr;

const char* kCell = R"(# the cell: a comment the engineer wrote
cycle: cell
axes:
  x:
    id: 1
    soft_limits: [0, 400]   # mm
    points: {pick: 50, place: 350}   # taught on the machine
  z:
    id: 2
    points:
      up: 5        # clear of the fixture
      nest: 70
  y: 3
  w: {id: 4, line: /dev/ttyUSB1}
steps:
  - move: {axis: x, to: pick}
)";

// The text with `from` replaced by `to` exactly once: what the edit must be.
std::string with(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  return text;
}

TEST(Teach, AnExistingPointInAFlowMapChangesOnlyItsValue) {
  const auto t = teach_point(kCell, "cell.yaml", "x.pick", 5525);
  EXPECT_EQ(t.text, with(kCell, "{pick: 50, place", "{pick: 55.25, place"));
  EXPECT_EQ(t.was_001mm, 5000);
  EXPECT_EQ(t.line, 7);
  // A bare point name that one axis has is that axis's.
  EXPECT_EQ(teach_point(kCell, "cell.yaml", "place", 30000).text,
            with(kCell, "place: 350}", "place: 300}"));
}

TEST(Teach, ANewPointInAFlowMapGoesLastAndKeepsTheComment) {
  const auto t = teach_point(kCell, "cell.yaml", "x.drop", 12000);
  EXPECT_EQ(t.text, with(kCell, "place: 350}   # taught", "place: 350, drop: 120}   # taught"));
  EXPECT_FALSE(t.was_001mm);
  EXPECT_EQ(parse_cycle(t.text, "cell.yaml").axes[0].points_001mm.at("drop"), 12000);
}

TEST(Teach, ABlockMapKeepsItsLayout) {
  EXPECT_EQ(teach_point(kCell, "cell.yaml", "z.up", 1000).text,
            with(kCell, "up: 5        #", "up: 10        #"));
  const auto t = teach_point(kCell, "cell.yaml", "z.deep", -250);
  EXPECT_EQ(t.text, with(kCell, "      nest: 70\n", "      nest: 70\n      deep: -2.5\n"));
  EXPECT_EQ(t.line, 13);
}

TEST(Teach, AnAxisWithoutPointsGetsThem) {
  // Written as its bare ID.
  EXPECT_EQ(teach_point(kCell, "cell.yaml", "y.home", 100).text,
            with(kCell, "  y: 3\n", "  y: {id: 3, points: {home: 1}}\n"));
  // A flow map.
  EXPECT_EQ(teach_point(kCell, "cell.yaml", "w.home", 100).text,
            with(kCell, "w: {id: 4", "w: {points: {home: 1}, id: 4"));
  // A block map: a line of its own, indented as its keys.
  const std::string block = "cycle: c\naxes:\n  x:\n    id: 1 # the slide\nsteps: [{dwell: 1s}]\n";
  EXPECT_EQ(teach_point(block, "c.yaml", "x.home", 100).text,
            "cycle: c\naxes:\n  x:\n    points: {home: 1}\n    id: 1 # the slide\nsteps: [{dwell: "
            "1s}]\n");
}

TEST(Teach, BadRequestsNameTheRuleAndWriteNothing) {
  const auto fails = [](const std::string& target, int32_t v) {
    try {
      teach_point(kCell, "cell.yaml", target, v);
    } catch (const CycleError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(fails("x.pick", 40001), HasSubstr("outside the axis's soft limits 0.00 to 400.00"));
  EXPECT_THAT(fails("q.pick", 100), HasSubstr("unknown axis 'q'"));
  EXPECT_THAT(fails("nowhere", 100), HasSubstr("no axis has a point 'nowhere': name it AXIS."));
  EXPECT_THAT(fails("x.9lives", 100), HasSubstr("is not a point name"));
  EXPECT_THAT(fails("x.a b", 100), HasSubstr("is not a point name"));
  // The same point in two axes must be named with its axis.
  const std::string both =
      "cycle: c\naxes:\n  x: {id: 1, points: {up: 1}}\n  z: {id: 2, points: "
      "{up: 2}}\nsteps: [{dwell: 1s}]\n";
  try {
    teach_point(both, "c.yaml", "up", 100);
    FAIL() << "no error";
  } catch (const CycleError& e) {
    EXPECT_THAT(e.what(), HasSubstr("name one, x.up or z.up"));
  }
  // A file that is not a valid cycle is refused as it is.
  EXPECT_THROW(teach_point("cycle: c\naxes: {}\nsteps: [{dwell: x}]\n", "c.yaml", "x.a", 1),
               CycleError);
}

}  // namespace
}  // namespace lec6::cycle
