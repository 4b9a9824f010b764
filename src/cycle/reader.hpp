#pragma once
// Reading YAML nodes with errors that name file, line, column and field
// (private to src/cycle/cycle_*.cpp). The style of lec serve's config reader.

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <string>
#include <vector>

#include "lec6/cycle/cycle_file.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::cycle::detail {

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}
  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& field,
                         const std::string& rule) const;
  static Mark mark(const YAML::Node& n);
  // Refuses keys outside `allowed`, suggesting the nearest one.
  void keys(const YAML::Node& map, const std::string& field,
            std::initializer_list<const char*> allowed) const;
  std::string text(const YAML::Node& n, const std::string& field) const;
  bool boolean(const YAML::Node& n, const std::string& field) const;
  int64_t integer(const YAML::Node& n, const std::string& field, int64_t min, int64_t max) const;
  // A length in mm (two decimals at most), as 0.01 mm.
  int32_t mm(const YAML::Node& n, const std::string& field) const;
  // A step-data field by the manual's ranges (lec::parse_field).
  int64_t step_field(const YAML::Node& n, const std::string& field, lec::StepField f) const;
  // "500ms", "2s", "1.5 s", "1min", or a number of seconds; > 0.
  Duration duration(const YAML::Node& n, const std::string& field) const;
  // `word` not among `known`: "unknown axis 'y' (axes: x, z)", with a suggestion when close.
  static std::string unknown(std::string_view what, const std::string& word,
                             const std::vector<std::string>& known, std::string_view list_name);

 private:
  std::string source_;
};

// One fault of the file's `faults:` list, or of --fault (cycle_faults.cpp).
Fault read_fault(const Reader& r, const YAML::Node& n, const std::string& field,
                 const Cycle& cycle);

// The cycle's steps (cycle_steps.cpp): a list of steps at `field`.
std::vector<Step> read_steps(const Reader& r, const YAML::Node& list, const std::string& field,
                             const Cycle& cycle, const std::vector<std::string>& branch_names);

}  // namespace lec6::cycle::detail
