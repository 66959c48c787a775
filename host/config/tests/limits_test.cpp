// Issue #13: a rig.toml is user input. Non-finite numbers, a grid the host cannot encode, a FIFO or a
// huge file in place of the rig.toml: each is one line naming the file and the key, never a hang or a
// configuration the host then fails on.
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_rig.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/proto.h"

namespace vc::config {
namespace {

using testing::edit;
using ::testing::HasSubstr;
using testing::TempRig;

std::string error_of(const TempRig& rig, const std::string& text) {
  try {
    (void)parse_rig_config(text, rig.toml_path());
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(RigConfigLimits, NonFiniteNumbersAreRefused) {
  TempRig rig;
  EXPECT_THAT(error_of(rig, edit("t_upper = 4.5", "t_upper = nan")),
              HasSubstr("subtraction.t_upper: must be a finite number, got nan"));
  EXPECT_THAT(error_of(rig, edit("voxel_m = 0.025", "voxel_m = inf")),
              HasSubstr("grid.voxel_m: must be a finite number, got inf"));
  EXPECT_THAT(error_of(rig, edit("min_m = [-1.0, -1.0, 0.0]", "min_m = [-inf, -1.0, 0.0]")),
              HasSubstr("grid.min_m[0]: must be a finite number, got -inf"));
}

// The case: a 600^3 grid passed `config check` and the host could not encode its CONFIG.
TEST(RigConfigLimits, GridOverTheProtocolLimitIsRefused) {
  TempRig rig;
  const std::string text =
      edit("nz = 90", "nz = 600", edit("ny = 80", "ny = 600", edit("nx = 80", "nx = 600")));
  EXPECT_THAT(
      error_of(rig, text),
      HasSubstr("grid: 600x600x600 = 216000000 voxels is over the protocol's limit of 134217728 (512^3)"));
  // 512^3 is exactly the limit and loads.
  const std::string at_limit =
      edit("nz = 90", "nz = 512", edit("ny = 80", "ny = 512", edit("nx = 80", "nx = 512")));
  EXPECT_EQ(error_of(rig, at_limit), "no error");
  EXPECT_EQ(uint64_t{512} * 512 * 512, VC_PROTO_MAX_VOXELS);
}

TEST(RigConfigLimits, OnlyABoundedRegularFileIsRead) {
  TempRig rig;
  const std::filesystem::path fifo = rig.dir() / "fifo.toml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)load_rig_config(fifo);  // returns at once: no writer is needed to refuse it
    ADD_FAILURE() << "a FIFO was read";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              fifo.string() + ": cannot open the rig configuration: not a regular file (a FIFO)");
  }
  const std::filesystem::path big = rig.dir() / "big.toml";
  std::ofstream(big) << testing::valid_toml() << "# " << std::string(kMaxRigTomlBytes, 'x') << "\n";
  try {
    (void)load_rig_config(big);
    ADD_FAILURE() << "an oversized file was read";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot open the rig configuration: larger than 1048576 bytes"));
  }
}

TEST(RigConfigLimits, EveryMessageIsOneLine) {
  TempRig rig;
  // A quoted key may hold a newline; so may a TOML parser's description.
  const std::string e1 = error_of(rig, testing::valid_toml() + "\"bad\\nkey\" = 1\n");
  EXPECT_THAT(e1, HasSubstr("unknown key"));
  EXPECT_EQ(e1.find('\n'), std::string::npos) << e1;
  const std::string e2 = error_of(rig, "version = 1\n[grid\n");
  EXPECT_THAT(e2, HasSubstr("TOML syntax error"));
  EXPECT_EQ(e2.find('\n'), std::string::npos) << e2;
}

}  // namespace
}  // namespace vc::config
