#pragma once
// Serves the dashboard's built files from one directory (http.web_root):
// GET and HEAD, index.html for a directory, a content type from the
// extension, validators (ETag, 304) and a cache rule that suits a bundler's
// output: index.html and other unhashed names are revalidated every time
// (`no-cache`), names carrying a content hash (`assets/index-4f3a2b1c.js`)
// are kept for a year (`immutable`).
//
// Nothing outside the root is ever served: the decoded path is checked
// segment by segment (no `..`, even as %2e%2e; no backslash, no NUL; no
// dot-files), and the file found must still be inside the root once symbolic
// links are resolved.
//
// Thread safety: const members may be called from any thread.

#include <filesystem>
#include <optional>
#include <string_view>

#include "http/http.hpp"

namespace lec6::serve {

class StaticFiles {
 public:
  explicit StaticFiles(std::filesystem::path root);

  // The answer to `request` (its decoded `path`): 200 / 304 / 404 / 405.
  HttpResponse serve(const HttpRequest& request) const;
  const std::filesystem::path& root() const noexcept { return root_; }

 private:
  std::filesystem::path root_;  // canonical when it exists
};

// The file a decoded URL path names, relative to the root ("/" → index.html,
// "/a/" → a/index.html); nullopt when the path may not be served.
std::optional<std::filesystem::path> static_relative_path(std::string_view decoded_path);

// "text/html; charset=utf-8" for .html...; application/octet-stream otherwise.
std::string_view content_type_for(const std::filesystem::path& file);

// Whether a file name carries a bundler's content hash ("index-4f3a2b1c.js",
// "app.8f9e0d1c2b3a.css"): a changed file gets a new name, so it may be cached.
bool is_hashed_asset(std::string_view file_name);

}  // namespace lec6::serve
