// Where the history is kept when nobody said (issue 32: on by default).

#include "serve/history/state_dir.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <string>

#include "serve/history/history.hpp"
#include "temp_dir.hpp"

namespace lec6::serve::history {
namespace {

std::optional<DefaultStateDir> with(std::map<std::string, std::string> env) {
  return default_state_dir([&env](const char* name) -> const char* {
    const auto it = env.find(name);
    return it == env.end() ? nullptr : it->second.c_str();
  });
}

TEST(StateDir, SystemdsStateDirectoryThenXdgStateHomeThenHome) {
  EXPECT_EQ(with({{"STATE_DIRECTORY", "/var/lib/lec6"}, {"HOME", "/home/u"}})->dir,
            "/var/lib/lec6");
  EXPECT_EQ(with({{"STATE_DIRECTORY", "/var/lib/lec6:/var/lib/other"}})->dir, "/var/lib/lec6");
  EXPECT_EQ(with({{"XDG_STATE_HOME", "/s"}, {"HOME", "/home/u"}})->dir, "/s/lec6");
  EXPECT_EQ(with({{"XDG_STATE_HOME", "/s"}})->from, "$XDG_STATE_HOME");
  // A relative XDG_STATE_HOME is invalid (the XDG spec): ignored.
  EXPECT_EQ(with({{"XDG_STATE_HOME", "rel"}, {"HOME", "/home/u"}})->dir,
            "/home/u/.local/state/lec6");
  EXPECT_EQ(with({{"HOME", "/home/u"}})->from, "$HOME");
  EXPECT_FALSE(with({}));
  EXPECT_FALSE(with({{"HOME", ""}, {"STATE_DIRECTORY", ""}}));
}

TEST(StateDir, AHistoryWithoutAStateDirIsKeptInTheDefaultOneAndSaysWhere) {
  testing::TempDir dir;
  const char* old = std::getenv("XDG_STATE_HOME");
  const std::string saved = old ? old : "";
  ::setenv("XDG_STATE_HOME", dir.path.c_str(), 1);
  std::string logged;
  {
    History h(HistoryConfig{}, {"x"}, [&](LogLevel, std::string_view t) { logged += t; });
    MotionRecord r;
    r.axis = "x";
    r.kind = "move";
    r.outcome = "reached";
    r.start_ms = system_ms();
    h.record(r);
  }
  old ? ::setenv("XDG_STATE_HOME", saved.c_str(), 1) : ::unsetenv("XDG_STATE_HOME");
  EXPECT_TRUE(std::filesystem::exists(dir.path / "lec6" / "history.db"));
  EXPECT_NE(logged.find((dir.path / "lec6" / "history.db").string()), std::string::npos) << logged;
  EXPECT_NE(logged.find("the default, from $XDG_STATE_HOME"), std::string::npos) << logged;
}

}  // namespace
}  // namespace lec6::serve::history
