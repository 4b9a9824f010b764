#include "lec/csv_reader.hpp"

#include <fmt/format.h>

#include <cctype>

namespace lec6::lec::csv {
namespace {

class Reader {
 public:
  Reader(std::string_view text, std::string_view separators)
      : text_(text), separators_(separators) {}

  std::vector<Record> run() {
    while (at_ < text_.size()) records_.push_back(record());
    return std::move(records_);
  }

 private:
  bool is_separator(char c) const { return separators_.find(c) != std::string_view::npos; }
  bool is_blank(char c) const { return (c == ' ' || c == '\t') && !is_separator(c); }
  bool at_end() const { return at_ >= text_.size(); }
  char peek() const { return text_[at_]; }

  // A line end at at_ (LF, or CRLF): its length, else 0.
  std::size_t line_end() const {
    if (at_end()) return 0;
    if (text_[at_] == '\n') return 1;
    if (text_[at_] == '\r' && at_ + 1 < text_.size() && text_[at_ + 1] == '\n') return 2;
    return 0;
  }

  Record record() {
    Record r;
    r.line = line_;
    const std::size_t start = at_;
    std::size_t raw_end = start;
    for (;;) {
      cell(r);
      if (!r.error.empty()) skip_line();
      raw_end = at_;
      if (const std::size_t n = line_end()) {
        at_ += n;
        ++line_;
        break;
      }
      if (at_end()) break;
      ++at_;  // a separator: the next cell
    }
    r.raw = text_.substr(start, raw_end - start);
    return r;
  }

  // One cell, from at_ to its separator or line end (not consumed).
  void cell(Record& r) {
    while (!at_end() && is_blank(peek())) ++at_;
    if (!at_end() && peek() == '"') {
      quoted(r);
      return;
    }
    const std::size_t begin = at_;
    while (!at_end() && !is_separator(peek()) && line_end() == 0) ++at_;
    std::string_view v = text_.substr(begin, at_ - begin);
    while (!v.empty() && std::isspace(static_cast<unsigned char>(v.back()))) v.remove_suffix(1);
    r.cells.emplace_back(v);
  }

  void quoted(Record& r) {
    const std::size_t column = r.cells.size() + 1;
    const std::size_t opened_on = line_;
    ++at_;  // the opening quote
    std::string v;
    for (;;) {
      if (at_end()) {
        r.cells.push_back(std::move(v));
        r.error = fmt::format(
            "cell {} opens a quote (line {}) that does not close before the end of the file",
            column, opened_on);
        return;
      }
      const char c = peek();
      if (c == '"') {
        if (at_ + 1 < text_.size() && text_[at_ + 1] == '"') {
          v += '"';
          at_ += 2;
          continue;
        }
        ++at_;  // the closing quote
        break;
      }
      if (const std::size_t n = line_end()) {  // a line break inside the cell
        v += '\n';
        at_ += n;
        ++line_;
        continue;
      }
      v += c;
      ++at_;
    }
    r.cells.push_back(std::move(v));
    while (!at_end() && is_blank(peek())) ++at_;
    if (!at_end() && !is_separator(peek()) && line_end() == 0) {
      r.error = fmt::format("cell {} has text after its closing quote", column);
    }
  }

  // After an error: on to the end of the physical line, quotes and all.
  void skip_line() {
    while (!at_end() && line_end() == 0) ++at_;
  }

  std::string_view text_;
  std::string_view separators_;
  std::size_t at_ = 0;
  std::size_t line_ = 1;
  std::vector<Record> records_;
};

}  // namespace

std::vector<Record> read(std::string_view text, std::string_view separators) {
  return Reader(text, separators).run();
}

}  // namespace lec6::lec::csv
