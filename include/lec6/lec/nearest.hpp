#pragma once
// "Did you mean": the one rule for every name a user can mistype — a command
// (`lec stauts`), a step field (`speed` in `lec step set`, a table column),
// a key of lec serve's configuration (`baudrate:`).
//
// Thread safety: pure functions, safe from any thread.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::lec {

// Edit distance (optimal string alignment): insertions, deletions,
// substitutions and swaps of two neighbouring letters ("stauts"), each 1.
std::size_t edit_distance(std::string_view a, std::string_view b);

// The index of the candidate `typed` most likely meant, or nullopt for a word
// far from all of them:
//  1. the candidate at the smallest edit distance (the first of equals), when
//     that distance is at most max(2, a third of the letters typed) and less
//     than half of them (a 2-letter word is nobody's typo);
//  2. else a candidate that starts with `typed`, or that `typed` starts with,
//     both at least 3 letters long ("baudrate" → "baud"): the first such.
std::optional<std::size_t> nearest_index(std::string_view typed,
                                         const std::vector<std::string>& candidates);
// The same, as the candidate itself.
std::optional<std::string> nearest(std::string_view typed,
                                   const std::vector<std::string>& candidates);

}  // namespace lec6::lec
