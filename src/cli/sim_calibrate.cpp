#include "cli/sim_calibrate.hpp"

#include <filesystem>

#include "cli/app.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/twin/calibrate.hpp"
#include "lec6/twin/replay.hpp"

namespace lec6::cli {

void run_calibrate(const std::string& file) {
  const modbus::Capture capture = transport::read_capture_file(file);
  const auto exchanges = twin::pair_exchanges(twin::line_records(capture));
  if (exchanges.empty()) {
    throw UsageError(fmt::format(
        "{}: the capture holds no query (no record with \"dir\": \"query\"): nothing to fit",
        file));
  }
  modbus::LineTiming line;
  line.baud = capture.header.line.baud;
  const auto c = twin::calibrate(exchanges, line);
  const std::string name = std::filesystem::path(file).stem().string() + "-calibrated";
  fmt::print("{}", c.profile_yaml(name, std::filesystem::path(file).filename().string()));
  fmt::print(stderr, "lec sim --calibrate: {} exchanges from {}\n{}", exchanges.size(), file,
             c.summary());
}

}  // namespace lec6::cli
