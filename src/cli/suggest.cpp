#include "cli/suggest.hpp"

#include <fmt/format.h>

#include "lec6/lec/nearest.hpp"

namespace lec6::cli {

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
  if (auto n = lec::nearest(*word, names)) {
    return fmt::format("unknown command '{}': did you mean '{}'? (`lec --help` lists the commands)",
                       *word, *n);
  }
  return fmt::format("unknown command '{}' (`lec --help` lists the commands)", *word);
}

}  // namespace lec6::cli
