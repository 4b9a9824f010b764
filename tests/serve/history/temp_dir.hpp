#pragma once
// A scratch directory for one history test, removed with everything in it.

#include <stdlib.h>

#include <filesystem>
#include <system_error>

namespace lec6::serve::history::testing {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char tmpl[] = "/tmp/lec6-history-XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

}  // namespace lec6::serve::history::testing
