#pragma once
// Files a command writes whole: a cycle file taught a point, a report
// (--report, --junit) written after the run. Written through a temporary
// beside the file and renamed over it, so a crash or a full disk never
// leaves half a file; a report is checked before the work it reports on
// starts, so that a run that moved the axes does not lose it.

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lec6::cli {

// Replaces (or creates) `path` with `text` whole. An existing file's
// permissions are kept. Throws CommandFailed (exit 1) saying why.
void replace_file(const std::string& path, const std::string& text);

// Each (option, path) a command will write: refuses (UsageError, exit 2) a
// directory or a path ending in '/', a path given twice, a path that is one
// of `inputs` (the files the command reads), and a path whose temporary
// cannot be created (tried, then removed: the directory takes a new file).
void check_outputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                   const std::vector<std::string>& inputs);

// replace_file, or what went wrong: "--report r.html: cannot write ...".
std::optional<std::string> write_output(const std::string& option, const std::string& path,
                                        const std::string& text);

}  // namespace lec6::cli
