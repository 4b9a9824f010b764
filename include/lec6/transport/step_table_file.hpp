#pragma once
// Step tables in files, for `lec step backup / restore / diff FILE` and the
// Python module's save/load: CSV or
// JSON by the file's extension (lec::table_format_for_path), written with
// transport::write_file_atomically (a crash leaves the old or the new file).

// Thread safety: the functions share nothing.

#include <filesystem>
#include <string>

#include "lec6/expected.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::transport {

// All or nothing: every error of the file, as parse_table reports them
// ("line 5 (step 3): speed_mm_s ..."); a file that cannot be read is one
// error naming the path and the cause.
Expected<lec::StepTable, lec::TableErrors> read_table_file(const std::filesystem::path& path);

// The error names the path and the cause.
Expected<void, std::string> write_table_file(const std::filesystem::path& path,
                                             const lec::StepTable& table);

}  // namespace lec6::transport
