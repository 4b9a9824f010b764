// The dashboard's files over HTTP.

#include "http/static_files.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <sstream>
#include <system_error>

namespace lec6::serve {

namespace fs = std::filesystem;

namespace {

bool is_hex(char c) {
  return std::isxdigit(static_cast<unsigned char>(c)) != 0;
}

bool is_alnum(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0;
}

// Whether `inner` is `root` or below it (both canonical).
bool inside(const fs::path& root, const fs::path& inner) {
  auto r = root.begin(), i = inner.begin();
  for (; r != root.end(); ++r, ++i) {
    if (i == inner.end() || *r != *i) return false;
  }
  return true;
}

std::optional<std::string> read_whole(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return s.str();
}

}  // namespace

std::optional<fs::path> static_relative_path(std::string_view decoded_path) {
  if (decoded_path.empty() || decoded_path.front() != '/') return std::nullopt;
  fs::path out;
  std::string_view rest = decoded_path.substr(1);
  bool directory = true;  // "/" and "/a/" name directories
  while (!rest.empty()) {
    const auto slash = rest.find('/');
    const std::string_view segment = rest.substr(0, slash);
    rest = slash == std::string_view::npos ? std::string_view() : rest.substr(slash + 1);
    directory = slash != std::string_view::npos;
    if (segment.empty()) {
      if (rest.empty()) break;
      return std::nullopt;  // "//": not a path a page of ours links to
    }
    // ".." climbs out; "." and dot-files (.git, .env) are never the dashboard.
    if (segment.front() == '.') return std::nullopt;
    if (segment.find_first_of(std::string_view("\\\0:", 3)) != std::string_view::npos)
      return std::nullopt;
    if (std::any_of(segment.begin(), segment.end(),
                    [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }))
      return std::nullopt;
    out /= std::string(segment);
  }
  if (directory || out.empty()) out /= "index.html";
  return out;
}

std::string_view content_type_for(const fs::path& file) {
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 16> kTypes{{
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".ico", "image/x-icon"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".webmanifest", "application/manifest+json"},
      {".woff2", "font/woff2"},
      {".woff", "font/woff"},
      {".txt", "text/plain; charset=utf-8"},
      {".wasm", "application/wasm"},
      {".webp", "image/webp"},
  }};
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const auto& [e, type] : kTypes) {
    if (e == ext) return type;
  }
  return "application/octet-stream";
}

bool is_hashed_asset(std::string_view name) {
  // The stem's last part after '-' or '.', 8 or more characters, letters and
  // digits mixed with at least one digit (Vite: base64url-ish; webpack: hex).
  const auto dot = name.rfind('.');
  if (dot == std::string_view::npos || dot == 0) return false;
  const std::string_view stem = name.substr(0, dot);
  const auto sep = stem.find_last_of("-.");
  if (sep == std::string_view::npos) return false;
  const std::string_view hash = stem.substr(sep + 1);
  if (hash.size() < 8) return false;
  bool digit = false;
  for (char c : hash) {
    if (!is_alnum(c) && c != '_') return false;
    digit = digit || std::isdigit(static_cast<unsigned char>(c));
  }
  return digit || std::all_of(hash.begin(), hash.end(), is_hex);
}

StaticFiles::StaticFiles(fs::path root) : root_(std::move(root)) {
  std::error_code ec;
  auto canonical = fs::canonical(root_, ec);
  if (!ec) root_ = std::move(canonical);
}

HttpResponse StaticFiles::serve(const HttpRequest& request) const {
  if (request.method != "GET" && request.method != "HEAD") {
    auto r = error_response(405, request.method + " is not allowed on the dashboard's files");
    r.headers.set("Allow", "GET, HEAD");
    return r;
  }
  auto not_found = [&] { return error_response(404, "no such file: " + request.path); };
  const auto relative = static_relative_path(request.path);
  if (!relative) return not_found();
  std::error_code ec;
  const fs::path file = fs::canonical(root_ / *relative, ec);
  if (ec || !inside(root_, file) || !fs::is_regular_file(file, ec)) return not_found();

  const auto size = fs::file_size(file, ec);
  const auto mtime = fs::last_write_time(file, ec);
  const std::string etag =
      fmt::format("\"{:x}-{:x}\"", size, static_cast<uint64_t>(mtime.time_since_epoch().count()));
  HttpResponse r;
  r.headers.set("ETag", etag);
  r.headers.set("Cache-Control", is_hashed_asset(file.filename().string())
                                     ? "public, max-age=31536000, immutable"
                                     : "no-cache");
  if (auto inm = request.header("If-None-Match"); inm && *inm == etag) {
    r.status = 304;
    return r;
  }
  auto body = read_whole(file);
  if (!body) return error_response(500, "cannot read " + request.path);
  r.status = 200;
  r.content_type = std::string(content_type_for(file));
  r.body = std::move(*body);
  return r;
}

}  // namespace lec6::serve
