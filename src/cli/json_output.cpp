#include "cli/json_output.hpp"

#include <fmt/format.h>

#include <cmath>

#include "lec6/lec/units.hpp"

namespace lec6::cli {
namespace {

// A scalar as nlohmann prints it.
std::string scalar(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

class Printer {
 public:
  explicit Printer(int indent) : indent_(indent) {}

  void value(const nlohmann::json& j, bool millimetres, int depth) {
    if (j.is_object()) {
      object(j, depth);
    } else if (j.is_array()) {
      array(j, millimetres, depth);
    } else if (millimetres && j.is_number()) {
      const double hundredths = std::round(j.get<double>() * 100.0);
      out_ += lec::format_mm(static_cast<int64_t>(hundredths));
    } else {
      out_ += scalar(j);
    }
  }

  std::string take() { return std::move(out_); }

 private:
  bool pretty() const { return indent_ >= 0; }

  void newline(int depth) {
    out_ += '\n';
    out_.append(static_cast<std::size_t>(depth * indent_), ' ');
  }

  void object(const nlohmann::json& j, int depth) {
    if (j.empty()) {
      out_ += "{}";
      return;
    }
    out_ += '{';
    bool first = true;
    for (const auto& [key, v] : j.items()) {
      if (!first) out_ += ',';
      first = false;
      if (pretty()) newline(depth + 1);
      out_ += scalar(nlohmann::json(key));
      out_ += pretty() ? ": " : ":";
      value(v, is_mm_key(key), depth + 1);
    }
    if (pretty()) newline(depth);
    out_ += '}';
  }

  // The elements of an array under an `_mm` key are millimetres too.
  void array(const nlohmann::json& j, bool millimetres, int depth) {
    if (j.empty()) {
      out_ += "[]";
      return;
    }
    out_ += '[';
    bool first = true;
    for (const auto& v : j) {
      if (!first) out_ += ',';
      first = false;
      if (pretty()) newline(depth + 1);
      value(v, millimetres, depth + 1);
    }
    if (pretty()) newline(depth);
    out_ += ']';
  }

  int indent_;
  std::string out_;
};

}  // namespace

nlohmann::json mm_json(int64_t value_001mm) {
  return static_cast<double>(value_001mm) / 100.0;
}

bool is_mm_key(std::string_view key) {
  return key.ends_with("_mm");
}

std::string dump_json(const nlohmann::json& j, int indent) {
  Printer p(indent);
  p.value(j, false, 0);
  return p.take();
}

void print_json(const nlohmann::json& j) {
  fmt::print("{}\n", dump_json(j, 2));
}

}  // namespace lec6::cli
