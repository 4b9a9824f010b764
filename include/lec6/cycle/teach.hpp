#pragma once
// Teach-in (issue 34): writes one named point of one axis into a cycle
// file's text, keeping everything else as it was (comments, layout, the order
// of keys, flow or block style). A YAML library would rewrite the file; the
// engineer's comments are part of the machine's documentation, so the text
// is edited where the parser says the point is (its byte offset).
//
//   x:
//     id: 1
//     points: {pick: 50, place: 350}     # an existing point: its value replaced
//                                        # a new one: ", name: MM" before the }
//
// The point's value must lie within the axis's soft limits; the edited text
// is read again as a cycle (every rule of cycle_file.hpp) before it is given
// back, so a file is never left broken. Errors are CycleErrors naming the
// file, line and column, the field and the rule.
//
// Attacked by tests/cycle/teach_test.cpp (flow and block maps, a new point,
// an axis without points or written as a bare ID, comments kept, soft limits,
// unknown axis or point names).
//
// Thread safety: a pure function.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lec6::cycle {

struct TaughtPoint {
  std::string text;  // the whole file's new text
  std::string axis, point;
  int32_t position_001mm = 0;
  std::optional<int32_t> was_001mm;  // the point's old value; none: added
  int line = 0;                      // where the value now is (1-based)
};

// `target` is "axis.point", or a point name that only one axis has.
TaughtPoint teach_point(std::string_view text, const std::string& source, const std::string& target,
                        int32_t position_001mm);

// The axis a target names (for reading its position before teaching):
// "axis.point" → axis; a bare point → the one axis that has it.
std::string teach_axis(std::string_view text, const std::string& source, const std::string& target);

}  // namespace lec6::cycle
