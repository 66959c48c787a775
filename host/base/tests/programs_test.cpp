// Where voxcap finds its sibling programs: beside itself, then <bin>/../libexec/voxcap, then the
// configured install prefix.
#include "voxcap/base/programs.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace {

namespace fs = std::filesystem;

TEST(Programs, SearchesBesideItselfThenLibexecThenThePrefix) {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const auto c = vc::program_candidates("voxcap-bench");
  ASSERT_GE(c.size(), 3u);
  EXPECT_EQ(c[0], self.parent_path() / "voxcap-bench");
  EXPECT_EQ(c[1], self.parent_path().parent_path() / "libexec" / "voxcap" / "voxcap-bench");
  bool prefix_bin = false, prefix_libexec = false;
  for (const fs::path& p : c) {
    prefix_bin |= p == fs::path(VOXCAP_TEST_BINDIR) / "voxcap-bench";
    prefix_libexec |= p == fs::path(VOXCAP_TEST_LIBEXECDIR) / "voxcap-bench";
  }
  EXPECT_TRUE(prefix_bin);
  EXPECT_TRUE(prefix_libexec);
}

TEST(Programs, FindsThisTestBinaryAndNotAMissingOne) {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  EXPECT_EQ(vc::find_program(self.filename().string()), self);
  EXPECT_TRUE(vc::find_program("voxcap-no-such-program").empty());
}

}  // namespace
