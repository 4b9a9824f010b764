#include "lec6/lec/nearest.hpp"

#include <algorithm>

namespace lec6::lec {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t w = b.size() + 1;
  std::vector<std::size_t> d((a.size() + 1) * w);
  auto at = [&](std::size_t i, std::size_t j) -> std::size_t& { return d[i * w + j]; };
  for (std::size_t i = 0; i <= a.size(); ++i) at(i, 0) = i;
  for (std::size_t j = 0; j <= b.size(); ++j) at(0, j) = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      at(i, j) = std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        at(i, j) = std::min(at(i, j), at(i - 2, j - 2) + 1);
    }
  }
  return at(a.size(), b.size());
}

std::optional<std::size_t> nearest_index(std::string_view typed,
                                         const std::vector<std::string>& candidates) {
  std::optional<std::size_t> best;
  std::size_t best_distance = 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const std::size_t d = edit_distance(typed, candidates[i]);
    if (!best || d < best_distance) {
      best = i;
      best_distance = d;
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, typed.size() / 3);
  if (best && best_distance <= limit && 2 * best_distance < typed.size()) return best;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const std::string_view c = candidates[i];
    if (std::min(c.size(), typed.size()) >= 3 && (c.starts_with(typed) || typed.starts_with(c)))
      return i;
  }
  return std::nullopt;
}

std::optional<std::string> nearest(std::string_view typed,
                                   const std::vector<std::string>& candidates) {
  const auto i = nearest_index(typed, candidates);
  if (!i) return std::nullopt;
  return candidates[*i];
}

}  // namespace lec6::lec
