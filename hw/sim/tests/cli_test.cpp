// `voxcap sim` end to end: exit codes, one-line errors, and the folder it writes.
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "voxcap/rig/calibration.hpp"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct CliRun {
  int code = -1;
  std::string output;
};

CliRun voxcap(const std::string& args) {
  const fs::path bin = fs::path(VOXCAP_BINARY_DIR) / "bin" / "voxcap";
  const std::string cmd = bin.string() + " " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) r.output += buf;
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(SimCli, WritesASequence) {
  const fs::path out = fs::path(::testing::TempDir()) / "vc_sim_cli";
  fs::remove_all(out);
  const CliRun r = voxcap(
      "sim --motion squat --frames 3 --cameras 4 --size 80x60 --backgrounds 2 --seed 3 "
      "--noise 1.5 --flicker 0.02 --appearance olive --room camouflage --distortion --quiet --out " +
      out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wrote 4 cameras x 3 frames"));
  const vc::rig::Calibration c = vc::rig::read_calibration((out / "rig.yaml").string());
  EXPECT_EQ(c.cameras.size(), 4u);
  EXPECT_EQ(c.cameras[0].width, 80);
  EXPECT_NE(c.cameras[0].dist[0], 0.0);
  for (const char* f :
       {"cam3/2.png", "background/cam0/1.png", "truth/silhouettes/cam1/0.png", "truth/shadows/cam2/1.png",
        "truth/joints.csv", "truth/features.csv", "truth/motion.bvh", "truth/scene.yaml"}) {
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;
  }
  std::ifstream joints(out / "truth" / "joints.csv");
  int lines = 0;
  for (std::string l; std::getline(joints, l);) ++lines;
  EXPECT_EQ(lines, 1 + 3 * 21);
  cv::FileStorage info((out / "truth" / "scene.yaml").string(), cv::FileStorage::READ);
  EXPECT_EQ(static_cast<std::string>(info["room"]), "camouflage");
  EXPECT_EQ(static_cast<std::string>(info["appearance"]), "olive");
}

TEST(SimCli, BadInputIsAOneLineUsageError) {
  const std::string out = (fs::path(::testing::TempDir()) / "vc_sim_cli_bad").string();
  CliRun r = voxcap("sim --motion moonwalk --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("unknown motion 'moonwalk'"));
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1);
  r = voxcap("sim --motion /no/such/clip.bvh --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("/no/such/clip.bvh"));
  r = voxcap("sim --size 640 --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("--size"));
  r = voxcap("sim --appearance purple --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("purple"));
  r = voxcap("sim --room cave --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("unknown room 'cave' (known: default, camouflage)"));
  r = voxcap("sim --frames 2");
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("--out"));
  r = voxcap("sim --list");
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.output, HasSubstr("arms-close"));
  EXPECT_THAT(r.output, HasSubstr("camouflage"));
}

}  // namespace
