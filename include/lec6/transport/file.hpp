#pragma once
// Whole files, read and written for the user's data (step-table backups, the
// twin's state file). One writer for all of them, so every file is replaced
// the same careful way.
//
// Thread safety: the functions share nothing; two writers of one path at once
// race (the last rename wins; neither file is torn).

#include <filesystem>
#include <string>
#include <string_view>

#include "lec6/expected.hpp"

namespace lec6::transport {

// The file's bytes. The error names the path and the cause:
// "cannot read steps.csv: No such file or directory".
Expected<std::string, std::string> read_file(const std::filesystem::path& path);

// The file a write to `path` should replace: for a symlink, the file it
// names (link by link, a relative target from its link's directory; a
// dangling link: the file it would create), so that a rename puts the new
// file where the link points and the user's link stays; otherwise, and for
// a loop of links, `path` itself. Every writer that renames over a path uses
// it, and refuses a target that is not a regular file (a link to a device
// would otherwise replace the device).
std::filesystem::path file_behind(const std::filesystem::path& path);

// Replaces `path` with `contents` so that a crash or a full disk leaves
// either the old file or the new one, never a mix: the bytes go to a hidden
// temporary file in the same directory (".NAME.tmp-XXXXXX"), which is
// fsync'ed, given the usual permissions (0666 less the umask), and renamed
// over `path`; then the directory is fsync'ed so the rename itself is on
// disk. A symlink `path` stays: the file it names is replaced (file_behind).
// On failure the temporary file is removed and `path` is untouched;
// the error names the path and the cause: "cannot write twin.state: ...".
Expected<void, std::string> write_file_atomically(const std::filesystem::path& path,
                                                  std::string_view contents);

}  // namespace lec6::transport
