#include "lec6/transport/step_table_file.hpp"

#include "lec6/transport/file.hpp"

namespace lec6::transport {

Expected<lec::StepTable, lec::TableErrors> read_table_file(const std::filesystem::path& path) {
  auto text = read_file(path);
  if (!text) return unexpected(lec::TableErrors{text.error()});
  return lec::parse_table(*text, lec::table_format_for_path(path.string()));
}

Expected<void, std::string> write_table_file(const std::filesystem::path& path,
                                             const lec::StepTable& table) {
  return write_file_atomically(path,
                               lec::format_table(table, lec::table_format_for_path(path.string())));
}

}  // namespace lec6::transport
