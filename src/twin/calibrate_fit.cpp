#include "calibrate_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace lec6::twin::fit {

std::vector<double> nelder_mead(const std::function<double(const std::vector<double>&)>& f,
                                std::vector<double> start, const std::vector<double>& step,
                                int iterations, double* value) {
  const std::size_t n = start.size();
  std::vector<std::vector<double>> p(n + 1, start);
  for (std::size_t i = 0; i < n; ++i) p[i + 1][i] += step[i];
  std::vector<double> y(n + 1);
  for (std::size_t i = 0; i <= n; ++i) y[i] = f(p[i]);
  auto combine = [&](const std::vector<double>& a, const std::vector<double>& b, double t) {
    std::vector<double> out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = a[i] + t * (b[i] - a[i]);
    return out;
  };
  for (int it = 0; it < iterations; ++it) {
    std::vector<std::size_t> order(n + 1);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return y[a] < y[b]; });
    const std::size_t best = order.front(), worst = order.back(), second = order[n - 1];
    if (std::abs(y[worst] - y[best]) <= 1e-14 * (std::abs(y[best]) + 1e-14)) break;
    std::vector<double> centroid(n, 0.0);
    for (std::size_t k = 0; k <= n; ++k) {
      if (k == worst) continue;
      for (std::size_t i = 0; i < n; ++i) centroid[i] += p[k][i] / static_cast<double>(n);
    }
    const auto reflected = combine(centroid, p[worst], -1.0);
    const double yr = f(reflected);
    if (yr < y[best]) {
      const auto expanded = combine(centroid, p[worst], -2.0);
      const double ye = f(expanded);
      if (ye < yr) {
        p[worst] = expanded;
        y[worst] = ye;
      } else {
        p[worst] = reflected;
        y[worst] = yr;
      }
    } else if (yr < y[second]) {
      p[worst] = reflected;
      y[worst] = yr;
    } else {
      const auto contracted = combine(centroid, p[worst], yr < y[worst] ? -0.5 : 0.5);
      const double yc = f(contracted);
      if (yc < std::min(yr, y[worst])) {
        p[worst] = contracted;
        y[worst] = yc;
      } else {
        for (std::size_t k = 0; k <= n; ++k) {
          if (k == best) continue;
          p[k] = combine(p[best], p[k], 0.5);
          y[k] = f(p[k]);
        }
      }
    }
  }
  const auto best = static_cast<std::size_t>(std::min_element(y.begin(), y.end()) - y.begin());
  if (value) *value = y[best];
  return p[best];
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : (v[m - 1] + v[m]) / 2.0;
}

double stddev(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s = 0;
  for (double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}

}  // namespace lec6::twin::fit
