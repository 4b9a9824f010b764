#pragma once
// Reading a cycle file (YAML, docs/cycles.md) into a Cycle, with every rule
// checked before anything moves. A bad file is a CycleError naming the file,
// the line and column, the field and the rule:
//
//   cell.yaml:14:17: steps[2].move.axis: unknown axis 'y' (axes: x, z)
//
// Attacked by tests/cycle/cycle_file_test.cpp (one case per rule).
//
// Thread safety: pure functions (they read only the text given).

#include <string>
#include <string_view>

#include "lec6/cycle/cycle.hpp"
#include "lec6/error.hpp"

namespace lec6::cycle {

class CycleError : public InvalidArgument {
 public:
  CycleError(std::string file, Mark at, std::string field, std::string rule);
  const std::string& file() const noexcept { return file_; }
  const Mark& at() const noexcept { return at_; }
  const std::string& field() const noexcept { return field_; }
  const std::string& rule() const noexcept { return rule_; }

 private:
  std::string file_;
  Mark at_;
  std::string field_;
  std::string rule_;
};

// `source` names the text in messages (the file's path).
Cycle parse_cycle(std::string_view yaml_text, const std::string& source);
// Reads the file; a file that cannot be read is a CycleError too.
Cycle load_cycle(const std::string& path);
// One fault as a YAML flow map, as in the file's `faults:` list (lec cycle
// run --fault '{step: 6, push_miss: z}'), checked against the cycle;
// `source` names it in messages ("--fault").
Fault parse_fault(std::string_view yaml_text, const std::string& source, const Cycle& cycle);
// The step at `path` ("6", "4.2", "no_part.1": a report's path without its
// pass), or nullptr. A parallel group's members have no path of their own.
const Step* find_step(const Cycle& cycle, std::string_view path);

}  // namespace lec6::cycle
