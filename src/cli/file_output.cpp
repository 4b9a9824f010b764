#include "cli/file_output.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "cli/app.hpp"
#include "lec6/transport/file.hpp"

namespace lec6::cli {

namespace fs = std::filesystem;

namespace {

fs::path temporary_of(const std::string& path) {
  return fs::path(path).concat(".lec-tmp");
}

// The same file however it is named ("./a.html", "a.html", a symlink, one
// that dangles: the file it would create).
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec1, ec2;
  const fs::path ca = fs::weakly_canonical(transport::file_behind(a), ec1);
  const fs::path cb = fs::weakly_canonical(transport::file_behind(b), ec2);
  return !ec1 && !ec2 ? ca == cb : a == b;
}

// A file that is there and is not a regular file (through a link too): a
// report renamed over it would replace a device, a FIFO or a directory.
std::optional<std::string> not_a_regular_file(const fs::path& target) {
  std::error_code ec;
  if (!fs::exists(target, ec) || fs::is_regular_file(target, ec)) return std::nullopt;
  return fmt::format("{} is not a regular file (a directory, a device or a FIFO): give a file name",
                     target.string());
}

}  // namespace

void replace_file(const std::string& given, const std::string& text) {
  // A symlink stays; the file it names is replaced.
  const std::string path = transport::file_behind(given).string();
  if (auto why = not_a_regular_file(path)) throw CommandFailed(kFailure, *why);
  const fs::path tmp = temporary_of(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) {
      const std::string why = std::strerror(errno);
      std::error_code ec;
      fs::remove(tmp, ec);
      throw CommandFailed(kFailure, fmt::format("cannot write {} ({}): nothing changed in {}",
                                                tmp.string(), why, path));
    }
  }
  std::error_code ec;
  if (const auto st = fs::status(path, ec); fs::exists(st)) {  // a new file: the umask's
    fs::permissions(tmp, st.permissions(), fs::perm_options::replace, ec);
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw CommandFailed(kFailure, fmt::format("cannot replace {}: {}", path, ec.message()));
  }
}

void check_outputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                   const std::vector<std::string>& inputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const auto& [option, path] = outputs[i];
    if (path.empty()) continue;
    std::error_code ec;
    if (path.back() == '/' || fs::is_directory(path, ec)) {
      throw UsageError(fmt::format("{} {}: a directory; give a file name", option, path));
    }
    // Where the write goes: through a link, the file it names.
    const fs::path target = transport::file_behind(path);
    if (auto why = not_a_regular_file(target)) {
      throw UsageError(fmt::format("{} {}: {}", option, path, *why));
    }
    for (const auto& in : inputs) {
      if (same_file(path, in))
        throw UsageError(fmt::format("{} {}: that is the file this command reads", option, path));
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (!outputs[j].second.empty() && same_file(path, outputs[j].second)) {
        throw UsageError(fmt::format("{} {}: also given to {}: each report needs its own file",
                                     option, path, outputs[j].first));
      }
    }
    const fs::path tmp = temporary_of(target.string());
    const bool existed = fs::exists(tmp, ec);
    {
      std::ofstream probe(tmp, std::ios::binary | std::ios::app);
      if (!probe) {
        throw UsageError(fmt::format("{} {}: cannot create a file there: {}", option, path,
                                     std::strerror(errno)));
      }
    }
    if (!existed) fs::remove(tmp, ec);
  }
}

std::optional<std::string> write_output(const std::string& option, const std::string& path,
                                        const std::string& text) {
  try {
    replace_file(path, text);
    return std::nullopt;
  } catch (const CommandFailed& e) {
    return fmt::format("{} {}: {}", option, path, e.what());
  }
}

}  // namespace lec6::cli
