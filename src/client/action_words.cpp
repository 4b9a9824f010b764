#include "lec6/client/action_words.hpp"

#include <array>
#include <regex>

namespace lec6::client {
namespace {

struct Action {
  const char* cli;     // a regex over the text between backquotes
  const char* http;    // {axis} and $1 (the step number) are filled in
  const char* python;  // $1 is filled in
};

constexpr std::array<Action, 9> kActions{{
    {R"(lec serial on)", R"(POST /api/axes/{axis}/serial {"on": true})", "axis.set_serial_mode(True)"},
    {R"(lec servo on)", R"(POST /api/axes/{axis}/servo {"on": true})", "axis.servo_on()"},
    {R"(lec home)", "POST /api/axes/{axis}/home", "axis.home()"},
    {R"(lec reset)", "POST /api/axes/{axis}/reset", "axis.reset()"},
    {R"(lec stop)", "POST /api/axes/{axis}/stop", "axis.stop()"},
    {R"(lec step set (\d+) \.\.\.)", "PUT /api/axes/{axis}/steps/$1", "axis.write_step($1, ...)"},
    {R"(lec step set N[^`]*)", "PUT /api/axes/{axis}/steps/N", "axis.write_step(n, ...)"},
    {R"(lec step get)", "GET /api/axes/{axis}/steps", "axis.read_step(n)"},
    {R"(lec servo off)", R"(POST /api/axes/{axis}/servo {"on": false})", "axis.servo_off()"},
}};

}  // namespace

std::string in_terms_of(std::string message, Interface to, std::string_view axis) {
  if (to == Interface::Cli || message.find("`lec ") == std::string::npos) return message;
  const std::string name = axis.empty() ? std::string("AXIS") : std::string(axis);
  for (const auto& a : kActions) {
    std::string words = to == Interface::Http ? a.http : a.python;
    if (const auto at = words.find("{axis}"); at != std::string::npos) words.replace(at, 6, name);
    const std::regex pattern(std::string("`") + a.cli + "`");
    message = std::regex_replace(message, pattern, "`" + words + "`");
  }
  return message;
}

}  // namespace lec6::client
