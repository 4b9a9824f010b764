#pragma once
// `lec sim --calibrate FILE` (private to cmd_sim.cpp): fits the twin to a
// capture and prints the profile on stdout, the fit's residuals and what it
// could not determine on stderr.

#include <string>

namespace lec6::cli {

void run_calibrate(const std::string& file);

}  // namespace lec6::cli
