// Writes the seed corpora: make_seeds TSV STEPS_DIR OUT_DIR creates
// OUT_DIR/<harness>/<seed> for every harness of harness.hpp, and the http
// harness's from seeds_http.hpp, the mbap harness's from harness_mbap.hpp.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "harness_mbap.hpp"
#include "seeds.hpp"
#include "seeds_http.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: make_seeds manual-frames.tsv STEPS_DIR OUT_DIR\n");
    return 2;
  }
  const std::string tsv = lec6::fuzz::read_file(argv[1]);
  if (tsv.empty()) {
    std::fprintf(stderr, "make_seeds: cannot read %s\n", argv[1]);
    return 1;
  }
  for (const auto& h : lec6::fuzz::harness_names()) {
    const std::filesystem::path dir = std::filesystem::path(argv[3]) / h;
    std::filesystem::create_directories(dir);
    for (const auto& [name, bytes] : lec6::fuzz::make_seeds(h, tsv, argv[2])) {
      std::ofstream out(dir / ("seed-" + name), std::ios::binary);
      out.write(reinterpret_cast<const char*>(bytes.data()),
                static_cast<std::streamsize>(bytes.size()));
    }
  }
  const std::filesystem::path http = std::filesystem::path(argv[3]) / "http";
  std::filesystem::create_directories(http);
  for (const auto& [name, text] : lec6::fuzz::http_seeds()) {
    std::ofstream out(http / ("seed-" + name), std::ios::binary);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  const std::filesystem::path mbap = std::filesystem::path(argv[3]) / "mbap";
  std::filesystem::create_directories(mbap);
  for (const auto& [name, bytes] : lec6::fuzz::mbap_seeds(tsv)) {
    std::ofstream out(mbap / ("seed-" + name), std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
  }
  return 0;
}
