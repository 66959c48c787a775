// Where the viewer finds its page (assets.hpp): the install layout relative to the binary first, the
// build tree second, and one line naming both when neither has it. On scratch trees.
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "voxcap/view/assets.hpp"

namespace vc::view {
namespace {

namespace fs = std::filesystem;

struct Assets : ::testing::Test {
  fs::path root;
  void SetUp() override {
    root = fs::temp_directory_path() / ("vc_view_assets_" + std::to_string(::getpid()));
    fs::remove_all(root);
    fs::create_directories(root / "usr" / "bin");
    fs::create_directories(root / "build" / "share" / "voxcap" / "web");
  }
  void TearDown() override { fs::remove_all(root); }
  void page(const fs::path& dir) {
    fs::create_directories(dir);
    std::ofstream(dir / "index.html") << "<!doctype html>";
  }
};

TEST_F(Assets, TheInstallLayoutBesideTheBinaryComesFirst) {
  const fs::path installed = root / "usr" / "share" / "voxcap" / "web";
  const fs::path build = root / "build" / "share" / "voxcap" / "web";
  page(installed);
  page(build);
  const AssetSearch s = find_assets(root / "usr" / "bin" / "voxcap", "../share/voxcap/web", build);
  EXPECT_EQ(s.dir, installed.lexically_normal());
  ASSERT_EQ(s.tried.size(), 2u);
  EXPECT_EQ(s.tried[1], build);
}

TEST_F(Assets, TheBuildTreeWhenTheBinaryHasNoPageBesideIt) {
  const fs::path build = root / "build" / "share" / "voxcap" / "web";
  page(build);
  // A test binary deep in the build tree: nothing at ../share/voxcap/web from its folder.
  const AssetSearch s =
      find_assets(root / "build" / "host" / "view" / "host_view_test", "../share/voxcap/web", build);
  EXPECT_EQ(s.dir, build);
  // A folder without index.html does not count.
  fs::create_directories(root / "usr" / "share" / "voxcap" / "web" / "lib");
  EXPECT_EQ(find_assets(root / "usr" / "bin" / "voxcap", "../share/voxcap/web", build).dir, build);
}

TEST_F(Assets, NoneFoundNamesEveryPlaceInOneLine) {
  const fs::path build = root / "build" / "share" / "voxcap" / "web";
  const AssetSearch s = find_assets(root / "usr" / "bin" / "voxcap", "../share/voxcap/web", build);
  EXPECT_TRUE(s.dir.empty());
  const std::string m = no_assets_message(s);
  EXPECT_EQ(m.find('\n'), std::string::npos);
  EXPECT_NE(m.find((root / "usr" / "share" / "voxcap" / "web").string()), std::string::npos) << m;
  EXPECT_NE(m.find(build.string()), std::string::npos) << m;
  EXPECT_NE(m.find("[viewer] assets"), std::string::npos) << m;
  // No build tree compiled in, no binary path: still one line that says so.
  const AssetSearch none = find_assets({}, "../share/voxcap/web", {});
  EXPECT_TRUE(none.tried.empty());
  EXPECT_NE(no_assets_message(none).find("unknown"), std::string::npos);
}

TEST(AssetsHere, ThisBuildFindsItsOwnPageOrNamesWhereItLooked) {
  // This test binary is not in bin/: the build tree's copy (voxcap_web, built with everything) or a
  // message naming it.
  const AssetSearch s = find_assets();
  ASSERT_FALSE(s.tried.empty());
  if (s.dir.empty())
    EXPECT_NE(no_assets_message(s).find("share/voxcap/web"), std::string::npos);
  else
    EXPECT_TRUE(fs::is_regular_file(s.dir / "index.html"));
}

}  // namespace
}  // namespace vc::view
