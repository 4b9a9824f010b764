// `--json` output (src/cli/json_output.cpp): nlohmann's layout byte for byte,
// and millimetres with two decimals under `_mm` keys.

#include "cli/json_output.hpp"

#include <gtest/gtest.h>

namespace lec6::cli {
namespace {

using nlohmann::json;

std::string reference(const json& j, int indent) {
  return j.dump(indent, ' ', false, json::error_handler_t::replace);
}

TEST(JsonOutput, LaysOutEveryTreeAsNlohmannDoes) {
  const json trees[] = {
      json::object(),
      json::array(),
      json(nullptr),
      json(true),
      json(-42),
      json(2.5),
      json(1e-7),
      json("text with \"quotes\", a tab\t and ü"),
      json::parse(R"({"b": [1, 2, {"c": []}], "a": {"x": {}, "y": [null, false]},
                      "speed_mm_s": 500, "ratio": 1.015, "name": "LEC6"})"),
      json::array({json::array(), json::object(), json::array({json::array({1})})}),
  };
  for (const auto& j : trees) {
    for (int indent : {-1, 0, 2, 4}) {
      EXPECT_EQ(dump_json(j, indent), reference(j, indent)) << j.dump();
    }
  }
  EXPECT_EQ(dump_json(json(std::string("bad \xff utf-8"))), reference(json("bad \xff utf-8"), -1));
}

TEST(JsonOutput, MillimetresHaveTwoDecimals) {
  const json j = {{"position_mm", mm_json(15000)},
                  {"target_mm", mm_json(-50)},
                  {"area1_mm", mm_json(-2147483647)},
                  {"zero_mm", mm_json(0)},
                  {"speed_mm_s", 500},
                  {"positions_mm", {mm_json(1), mm_json(12345)}},
                  {"nested", {{"in_position_mm", mm_json(100)}}}};
  EXPECT_EQ(dump_json(j),
            R"({"area1_mm":-21474836.47,"nested":{"in_position_mm":1.00},"position_mm":150.00,)"
            R"("positions_mm":[0.01,123.45],"speed_mm_s":500,"target_mm":-0.50,"zero_mm":0.00})");
  // The tree holds numbers, not text: a program reading it gets millimetres.
  EXPECT_DOUBLE_EQ(j["position_mm"].get<double>(), 150.0);
}

TEST(JsonOutput, OnlyKeysInMillimetresAreFormattedAsMillimetres) {
  EXPECT_TRUE(is_mm_key("position_mm"));
  EXPECT_FALSE(is_mm_key("speed_mm_s"));
  EXPECT_FALSE(is_mm_key("mm"));
  EXPECT_EQ(dump_json(json{{"round_trip_ms", 1.5}}), R"({"round_trip_ms":1.5})");
}

}  // namespace
}  // namespace lec6::cli
