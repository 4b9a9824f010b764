#pragma once
// Small numeric helpers of the calibration (calibrate*.cpp): a Nelder-Mead
// minimiser and robust statistics. Private to twin/.

#include <functional>
#include <vector>

namespace lec6::twin::fit {

// Minimises f from `start` (initial simplex: start ± step per coordinate).
// Returns the best point found; `value` receives f there.
std::vector<double> nelder_mead(const std::function<double(const std::vector<double>&)>& f,
                                std::vector<double> start, const std::vector<double>& step,
                                int iterations, double* value = nullptr);

double median(std::vector<double> v);
double stddev(const std::vector<double>& v);

}  // namespace lec6::twin::fit
