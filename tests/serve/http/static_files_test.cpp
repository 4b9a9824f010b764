// The dashboard's files: index, content types, caching, and nothing outside
// the root, however the path is spelled.

#include "http/static_files.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "http/http_codec.hpp"

namespace lec6::serve {
namespace {

namespace fs = std::filesystem;

class StaticFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    base_ = fs::temp_directory_path() /
            ("lec6-static-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(base_);
    root_ = base_ / "web";
    fs::create_directories(root_ / "assets");
    write(root_ / "index.html", "<!doctype html><title>lec6</title>");
    write(root_ / "assets" / "index-4f3a2b1c.js", "console.log(1)");
    write(root_ / "assets" / "style.css", "body{}");
    write(root_ / "assets" / "logo.svg", "<svg/>");
    write(root_ / "assets" / "index.html", "<p>assets index</p>");
    write(root_ / ".env", "SECRET=1");
    write(base_ / "secret.txt", "outside the root");
    fs::create_symlink(base_ / "secret.txt", root_ / "link.txt");
  }
  void TearDown() override { fs::remove_all(base_); }

  static void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

  HttpResponse get(const std::string& target, const std::string& method = "GET") {
    // Through the real reader, so %-decoding is the server's.
    HttpRequestReader reader;
    const auto status = reader.feed(method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    if (status != HttpRequestReader::Status::Complete) return error_response(400, "bad request");
    return StaticFiles(root_).serve(reader.take());
  }

  fs::path base_, root_;
};

TEST_F(StaticFilesTest, ServesIndexForTheRootAndForADirectory) {
  auto r = get("/");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "<!doctype html><title>lec6</title>");
  EXPECT_EQ(r.content_type, "text/html; charset=utf-8");
  EXPECT_EQ(r.headers.find("Cache-Control").value_or(""), "no-cache");
  EXPECT_EQ(get("/assets/").body, "<p>assets index</p>");
  EXPECT_EQ(get("/index.html").status, 200);
}

TEST_F(StaticFilesTest, GivesContentTypesAndCachesHashedAssetsLong) {
  auto js = get("/assets/index-4f3a2b1c.js");
  EXPECT_EQ(js.status, 200);
  EXPECT_EQ(js.content_type, "text/javascript; charset=utf-8");
  EXPECT_EQ(js.headers.find("Cache-Control").value_or(""), "public, max-age=31536000, immutable");
  auto css = get("/assets/style.css");
  EXPECT_EQ(css.content_type, "text/css; charset=utf-8");
  EXPECT_EQ(css.headers.find("Cache-Control").value_or(""), "no-cache");
  EXPECT_EQ(get("/assets/logo.svg").content_type, "image/svg+xml");
  EXPECT_EQ(content_type_for("a.png"), "image/png");
  EXPECT_EQ(content_type_for("a.JSON"), "application/json");
  EXPECT_EQ(content_type_for("a.js.map"), "application/json");
  EXPECT_EQ(content_type_for("f.woff2"), "font/woff2");
  EXPECT_EQ(content_type_for("x.bin"), "application/octet-stream");
  EXPECT_TRUE(is_hashed_asset("app.8f9e0d1c2b3a.css"));
  EXPECT_FALSE(is_hashed_asset("index.html"));
  EXPECT_FALSE(is_hashed_asset("my-component.js"));
}

TEST_F(StaticFilesTest, AnswersNotModifiedToAMatchingETag) {
  auto first = get("/assets/style.css");
  const std::string etag(first.headers.find("ETag").value_or(""));
  ASSERT_FALSE(etag.empty());
  HttpRequest again;
  again.method = "GET";
  again.path = "/assets/style.css";
  again.headers.add("If-None-Match", etag);
  auto r = StaticFiles(root_).serve(again);
  EXPECT_EQ(r.status, 304);
  EXPECT_TRUE(r.body.empty());
}

TEST_F(StaticFilesTest, RefusesEveryWayOutOfTheRoot) {
  for (const char* target :
       {"/../secret.txt", "/assets/../../secret.txt", "/%2e%2e/secret.txt", "/%2E%2E/secret.txt",
        "/assets/%2e%2e/%2e%2e/secret.txt", "/..%2fsecret.txt", "/%2e%2e%2fsecret.txt",
        "/assets/..%5c..%5csecret.txt", "/link.txt", "/.env", "/%2eenv", "//etc/passwd",
        "/assets/./style.css", "/nothing.html", "/assets"}) {
    auto r = get(target);
    EXPECT_TRUE(r.status == 404 || r.status == 400) << target << " -> " << r.status;
    EXPECT_EQ(r.body.find("outside the root"), std::string::npos) << target;
    EXPECT_EQ(r.body.find("SECRET"), std::string::npos) << target;
  }
  EXPECT_FALSE(static_relative_path("/a/../b"));
  EXPECT_FALSE(static_relative_path("relative"));
  EXPECT_EQ(static_relative_path("/a/b.js").value(), fs::path("a/b.js"));
}

TEST_F(StaticFilesTest, OnlyGetAndHeadAreAllowed) {
  auto r = get("/index.html", "POST");
  EXPECT_EQ(r.status, 405);
  EXPECT_EQ(r.headers.find("Allow").value_or(""), "GET, HEAD");
  EXPECT_EQ(get("/index.html", "HEAD").status, 200);
}

}  // namespace
}  // namespace lec6::serve
