// The one place a browser's path becomes a file name: traversal and odd targets refused.
#include <fstream>

#include <gtest/gtest.h>

#include "voxcap/view/http_path.hpp"

namespace vc::view {
namespace {

std::string ok(std::string_view t) {
  std::string rel, why;
  EXPECT_TRUE(resolve_target(t, &rel, &why)) << t << ": " << why;
  return rel;
}
bool refused(std::string_view t) {
  std::string rel, why;
  return !resolve_target(t, &rel, &why);
}

TEST(ViewHttpPath, MapsTargetsToFiles) {
  EXPECT_EQ(ok("/"), "index.html");
  EXPECT_EQ(ok("/app.js"), "app.js");
  EXPECT_EQ(ok("/lib/three.module.js?v=3#x"), "lib/three.module.js");
  EXPECT_EQ(ok("/lib/"), "lib/index.html");
  EXPECT_EQ(ok("/%61pp.js"), "app.js");
}

TEST(ViewHttpPath, RefusesTraversalAndOddTargets) {
  for (const char* t :
       {"/../etc/passwd", "/lib/../../x", "/..", "/%2e%2e/x", "/%2E%2E%2Fetc", "/.git/config", "/lib/.hidden",
        "/a//b", "relative", "", "/a\\b", "/a%00b", "/%", "/%4", "/%zz", "/a b", "http://host/x", "/./x"})
    EXPECT_TRUE(refused(t)) << t;
  EXPECT_TRUE(refused("/" + std::string(kMaxTarget, 'a')));
}

TEST(ViewHttpPath, MimeTypes) {
  EXPECT_EQ(mime_type("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(mime_type("lib/three.module.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(mime_type("style.css"), "text/css; charset=utf-8");
  EXPECT_EQ(mime_type("x.bin"), "application/octet-stream");
}

TEST(ViewHttpPath, AssetFileStaysInsideTheFolder) {
  const auto root = std::filesystem::temp_directory_path() / ("vc_view_assets_" + std::to_string(::getpid()));
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root / "www");
  std::ofstream(root / "www" / "index.html") << "hi";
  std::ofstream(root / "secret.txt") << "no";
  std::filesystem::create_symlink(root / "secret.txt", root / "www" / "link.txt");
  std::filesystem::path out;
  std::string why;
  EXPECT_TRUE(asset_file(root / "www", "index.html", &out, &why)) << why;
  EXPECT_FALSE(asset_file(root / "www", "link.txt", &out, &why));  // a symlink out of the folder
  EXPECT_FALSE(asset_file(root / "www", "missing.js", &out, &why));
  std::filesystem::create_directories(root / "www" / "dir");
  EXPECT_FALSE(asset_file(root / "www", "dir", &out, &why));  // not a file
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace vc::view
