// `lec step ...`: placeholder until the step-table commands land.
#include "cli/app.hpp"

namespace lec6::cli {
void add_step_commands(CLI::App&, Session&) {}
}  // namespace lec6::cli
