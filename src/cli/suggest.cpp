#include "cli/suggest.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace lec6::cli {

// Optimal string alignment: Levenshtein plus the swap of two neighbours,
// the commonest typo ("stauts").
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

std::optional<std::string> nearest(std::string_view typed, const std::vector<std::string>& names) {
  std::optional<std::string> best;
  std::size_t best_distance = 0;
  for (const auto& n : names) {
    const std::size_t d = edit_distance(typed, n);
    if (!best || d < best_distance) {
      best = n;
      best_distance = d;
    }
  }
  if (!best || best_distance > 2 || 2 * best_distance >= typed.size()) return std::nullopt;
  return best;
}

namespace {

// The first word of argv that is neither an option nor an option's value.
std::optional<std::string> command_word(const CLI::App& app, int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view word = argv[i];
    if (word == "--") return std::nullopt;
    if (word.size() > 1 && word.front() == '-') {
      if (word.find('=') != std::string_view::npos) continue;
      const CLI::Option* opt = app.get_option_no_throw(std::string(word));
      if (opt && opt->get_expected_min() > 0) ++i;  // its value follows
      continue;
    }
    return std::string(word);
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> unknown_command_message(const CLI::App& app, int argc,
                                                   const char* const* argv) {
  const auto word = command_word(app, argc, argv);
  if (!word) return std::nullopt;
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (sub->get_name() == *word) return std::nullopt;
    names.push_back(sub->get_name());
  }
  if (auto n = nearest(*word, names)) {
    return fmt::format("unknown command '{}': did you mean '{}'? (`lec --help` lists the commands)",
                       *word, *n);
  }
  return fmt::format("unknown command '{}' (`lec --help` lists the commands)", *word);
}

}  // namespace lec6::cli
