// The twin's state file: its text (sim/state_file.hpp) and the file on disk
// (twin/state_file_io.hpp).

#include "lec6/sim/state_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "lec6/lec/memory_map.hpp"
#include "lec6/twin/state_file_io.hpp"

namespace lec6::sim {
namespace {

namespace fs = std::filesystem;
using twin::load_state_file;  // the file on disk; its text is sim's
using twin::save_state_file;

Eeprom sample() {
  Eeprom e;
  e.name = *lec::EquipmentName::make("Line 3 press");
  e.steps[1].movement_mode = lec::MovementMode::Absolute;
  e.steps[1].speed_mm_s = 500;
  e.steps[1].position_001mm = -15000;
  e.steps[1].in_position_001mm = 2147483647;
  e.steps[63].movement_mode = lec::MovementMode::Incremental;
  e.steps[63].area1_001mm = -1;
  e.step_writes[1] = 7;
  e.step_writes[2] = 1;  // written back to blank: still counted
  e.alarms.groups[0].codes = {51, 0, 0, 0, 0, 0, 0, 0};
  e.alarms.groups[15].codes = {149, 52, 0, 0, 0, 0, 0, 255};
  return e;
}

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("lec6-sim-state-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST(StateFile, SerializeParseRoundTrip) {
  EepromSet set{{1, sample()}, {32, Eeprom{}}};
  const std::string text = serialize_state(set);
  EXPECT_NE(text.find("name Line 3 press\n"), std::string::npos);
  EXPECT_NE(text.find("step 1 writes 7 0001 01F4 FFFF C568"), std::string::npos);
  auto back = parse_state(text);
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(*back, set);
}

TEST(StateFile, ParseErrorsNameTheLine) {
  EXPECT_FALSE(parse_state(""));
  EXPECT_FALSE(parse_state("something else\n"));
  auto e = parse_state("lec6-twin-state 1\ncontroller 1\nstep 64 writes 0\nend\n");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().find("line 3"), std::string::npos);
  EXPECT_FALSE(parse_state("lec6-twin-state 1\ncontroller 0\nend\n"));
  EXPECT_FALSE(parse_state("lec6-twin-state 1\ncontroller 1\nname fifteen chars..\nend\n"));
  EXPECT_FALSE(parse_state("lec6-twin-state 1\ncontroller 1\n"));  // no end
  EXPECT_FALSE(parse_state("lec6-twin-state 1\nname x\n"));        // outside a section
  EXPECT_TRUE(parse_state("lec6-twin-state 1\n# comment\n\ncontroller 2\nend\n"));
}

TEST_F(TempDir, SaveLoadRoundTrip) {
  const fs::path p = dir / "twin.state";
  auto none = load_state_file(p);
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->has_value());  // first start

  EepromSet set{{1, sample()}};
  ASSERT_TRUE(save_state_file(p, set));
  auto loaded = load_state_file(p);
  ASSERT_TRUE(loaded) << loaded.error();
  ASSERT_TRUE(loaded->has_value());
  EXPECT_EQ(**loaded, set);

  // A controller powered on from it reads the EEPROM back.
  Controller c({}, TimePoint{}, (**loaded).at(1));
  auto r = c.handle(modbus::ReadRegistersRequest{lec::step_address(1), 4}, TimePoint{});
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(r).values,
            (std::vector<uint16_t>{1, 500, 0xFFFF, 0xC568}));
  r = c.handle(modbus::ReadRegistersRequest{lec::kEquipmentName, 8}, TimePoint{});
  EXPECT_EQ(
      lec::EquipmentName::from_registers(std::get<modbus::ReadRegistersResponse>(r).values).text,
      "Line 3 press");
  EXPECT_EQ(c.eeprom().step_writes[1], 7u);
}

TEST_F(TempDir, SaveIsAtomicTempThenRename) {
  const fs::path p = dir / "twin.state";
  ASSERT_TRUE(save_state_file(p, {{1, Eeprom{}}}));
  struct stat before {};
  ASSERT_EQ(::stat(p.c_str(), &before), 0);
  // A reader holding the old file keeps seeing the old content: the new one
  // is a different file renamed over it, not the old one rewritten in place.
  std::ifstream old_reader(p);
  EepromSet next{{1, sample()}};
  ASSERT_TRUE(save_state_file(p, next));
  struct stat after {};
  ASSERT_EQ(::stat(p.c_str(), &after), 0);
  EXPECT_NE(before.st_ino, after.st_ino);
  std::string old_text((std::istreambuf_iterator<char>(old_reader)),
                       std::istreambuf_iterator<char>());
  EXPECT_EQ(old_text, serialize_state({{1, Eeprom{}}}));
  EXPECT_EQ(**load_state_file(p), next);
  // No temporary file is left behind.
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "twin.state");
  }
  EXPECT_EQ(files, 1u);
}

TEST_F(TempDir, SaveIntoMissingDirectoryFailsCleanly) {
  auto r = save_state_file(dir / "no" / "such" / "twin.state", {{1, Eeprom{}}});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("no/such"), std::string::npos);
}

TEST_F(TempDir, LoadRejectsGarbage) {
  const fs::path p = dir / "twin.state";
  std::ofstream(p) << "{\"not\": \"ours\"}\n";
  auto r = load_state_file(p);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("twin.state"), std::string::npos);
}

TEST(StateFile, ControllerEepromGenerationTracksChanges) {
  Controller c;
  const uint64_t g0 = c.eeprom_generation();
  (void)c.handle(modbus::WriteCoilRequest{0x30, modbus::kCoilOn}, TimePoint{});
  EXPECT_EQ(c.eeprom_generation(), g0);  // flags are RAM
  const uint16_t one = 1;
  (void)c.handle(modbus::WriteRegistersRequest::of(lec::step_address(0), std::span(&one, 1)),
                 TimePoint{});
  EXPECT_GT(c.eeprom_generation(), g0);
  c.restore_eeprom(sample());
  EXPECT_EQ(c.eeprom(), sample());
}

}  // namespace
}  // namespace lec6::sim
