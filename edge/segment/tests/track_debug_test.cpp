// `voxcap track debug` end to end (runs the built voxcap binary): --sim wave writes one picture per
// camera and segmentation.json with ok, terminals and the 2D error against the truth; --images reads
// a folder in the documented layout; bad input is a one-line error with exit code 2.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/sim/scene.hpp"

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

nlohmann::json read_json(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f);
}

TEST(TrackDebug, SimWaveWritesPicturesAndJson) {
  const fs::path out = fs::path(::testing::TempDir()) / "vc_track_debug_sim";
  fs::remove_all(out);
  const CliRun r = voxcap("track debug --sim wave --cameras 4 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("4/4 cameras segmented"));
  const nlohmann::json j = read_json(out / "segmentation.json");
  ASSERT_EQ(j.at("cameras").size(), 4U);
  EXPECT_EQ(j.at("ok_cameras"), 4);
  EXPECT_EQ(j.at("source"), "sim");
  for (int c = 0; c < 4; c++) {
    const nlohmann::json& cam = j.at("cameras").at(static_cast<size_t>(c));
    const cv::Mat img = cv::imread((out / cam.at("image").get<std::string>()).string());
    ASSERT_FALSE(img.empty()) << cam.at("image");
    EXPECT_EQ(img.cols, 640);
    EXPECT_TRUE(cam.at("ok").get<bool>()) << cam.at("why");
    for (const char* f : {"head", "left_hand", "right_hand", "left_foot", "right_foot"}) {
      const nlohmann::json& t = cam.at("terminals").at(f);
      EXPECT_GE(t.at("region").get<int>(), 0) << f;
      EXPECT_LT(t.at("error_px").get<double>(), 23.0)
          << "cam " << c << " " << f;  // 10 % of the ~230 px height
    }
  }
  EXPECT_LT(j.at("error_px").at("median").get<double>(), 4.0);
}

TEST(TrackDebug, ImagesFolder) {
  // A real rig's layout, made from the virtual rig: camNN.png and camNN_bg*.png.
  const fs::path in = fs::path(::testing::TempDir()) / "vc_track_debug_in";
  const fs::path out = fs::path(::testing::TempDir()) / "vc_track_debug_out";
  fs::remove_all(in);
  fs::remove_all(out);
  fs::create_directories(in);
  vc::sim::SceneOptions o;
  o.motion.source = "wave";
  o.rig.cameras = 4;
  const vc::sim::Scene scene(o);
  cv::Mat rgb, bgr;
  for (int cam : {0, 1}) {
    scene.render(0, cam, rgb);
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    cv::imwrite((in / ("cam0" + std::to_string(cam) + ".png")).string(), bgr);
    for (int i = 0; i < 6; i++) {
      scene.render_background(cam, i, rgb);
      cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
      cv::imwrite((in / ("cam0" + std::to_string(cam) + "_bg" + std::to_string(i) + ".png")).string(), bgr);
    }
  }
  const CliRun r = voxcap("track debug --images " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json j = read_json(out / "segmentation.json");
  EXPECT_EQ(j.at("source"), "images");
  EXPECT_EQ(j.at("ok_cameras"), 2) << j.dump();
  EXPECT_TRUE(fs::exists(out / "cam00.png"));
  EXPECT_TRUE(fs::exists(out / "cam01.png"));

  // No background for a camera: named in a one-line error.
  fs::remove(in / "cam01_bg0.png");
  for (int i = 1; i < 6; i++) fs::remove(in / ("cam01_bg" + std::to_string(i) + ".png"));
  const CliRun bad = voxcap("track debug --images " + in.string() + " --out " + out.string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_THAT(bad.output, HasSubstr("cam01 has no background"));
}

TEST(TrackDebug, BadInput) {
  const std::string out = (fs::path(::testing::TempDir()) / "vc_track_debug_bad").string();
  EXPECT_EQ(voxcap("track debug --out " + out).code, 2);
  EXPECT_EQ(voxcap("track debug --sim wave --images /tmp --out " + out).code, 2);
  const CliRun r = voxcap("track debug --sim moonwalk --out " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.output, HasSubstr("moonwalk"));
  EXPECT_EQ(voxcap("track debug --images /no/such/dir --out " + out).code, 2);
}

}  // namespace
