// Camera backends on a real board (label hil). Skipped unless the rig is named in the environment:
//   VOXCAP_HIL_V4L2_DEVICE=/dev/video0  [VOXCAP_HIL_V4L2_FORMAT=yuyv] [VOXCAP_HIL_SIZE=640x480] [VOXCAP_HIL_FPS=60]
//   VOXCAP_HIL_LIBCAMERA=0,1            [VOXCAP_HIL_EXPOSURE_US=4000] [VOXCAP_HIL_SIZE] [VOXCAP_HIL_FPS]
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "hil_env.hpp"
#include "voxcap/edge/camera.h"

namespace {

using vc::hil::env;
using vc::hil::env_long;

struct Summary {
  int frames = 0;
  bool increasing = true;
  uint64_t first_t = 0, last_t = 0;
};

// Captures n frames, checking what a working camera guarantees; prints the measured period.
Summary stream(vc_camera* cam, int n) {
  Summary s;
  for (int i = 0; i < n; i++) {
    vc_frame f;
    int rc = vc_camera_capture(cam, 2000, &f);
    EXPECT_EQ(rc, 0) << vc_camera_last_error(cam);
    if (rc) break;
    EXPECT_TRUE(f.flags & VC_FRAME_TS_DRIVER) << "the driver gave no capture timestamp";
    if (s.frames == 0) s.first_t = f.t_ns;
    if (s.frames > 0 && f.t_ns <= s.last_t) s.increasing = false;
    s.last_t = f.t_ns;
    s.frames++;
    vc_camera_release(cam, &f);
  }
  vc_camera_stats st;
  vc_camera_get_stats(cam, &st);
  if (s.frames > 1)
    std::printf("hil: %d frames, mean period %.3f ms, dropped %llu, corrupted %llu\n", s.frames,
                (double)(s.last_t - s.first_t) / 1e6 / (s.frames - 1), (unsigned long long)st.dropped,
                (unsigned long long)st.corrupted);
  return s;
}

void apply_common(vc_camera_config* cfg) {
  std::string size = env("VOXCAP_HIL_SIZE");
  if (!size.empty()) std::sscanf(size.c_str(), "%dx%d", &cfg->width, &cfg->height);
  cfg->fps_num = (uint32_t)env_long("VOXCAP_HIL_FPS", 0);
  cfg->fps_den = 1;
}

TEST(V4l2Hil, StreamsFromTheConfiguredDevice) {
  std::string dev = env("VOXCAP_HIL_V4L2_DEVICE");
  if (dev.empty()) GTEST_SKIP() << "no rig configured: set VOXCAP_HIL_V4L2_DEVICE=/dev/videoN to run";
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  cfg.backend = "v4l2";
  cfg.device = dev.c_str();
  apply_common(&cfg);
  std::string fmt = env("VOXCAP_HIL_V4L2_FORMAT", "yuyv");
  ASSERT_EQ(vc_pixfmt_from_name(fmt.c_str(), &cfg.pixfmt), 0) << "unknown format " << fmt;
  vc_camera* cam = nullptr;
  char why[320];
  ASSERT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), 0) << why;
  ASSERT_EQ(vc_camera_start(cam), 0) << vc_camera_last_error(cam);
  Summary s = stream(cam, 120);
  EXPECT_EQ(s.frames, 120);
  EXPECT_TRUE(s.increasing);
  vc_camera_free(cam);
}

TEST(LibcameraHil, TwoCamerasAtOnce) {
  std::string list = env("VOXCAP_HIL_LIBCAMERA");
  if (list.empty()) GTEST_SKIP() << "no rig configured: set VOXCAP_HIL_LIBCAMERA=0,1 (indexes or ids) to run";
  std::vector<std::string> ids;
  std::stringstream ss(list);
  for (std::string id; std::getline(ss, id, ',');) ids.push_back(id);
  std::vector<vc_camera*> cams;
  for (const auto& id : ids) {
    vc_camera_config cfg;
    vc_camera_config_init(&cfg);
    cfg.backend = "libcamera";
    cfg.device = id.c_str();
    apply_common(&cfg);
    cfg.exposure_us = env_long("VOXCAP_HIL_EXPOSURE_US", 0);
    vc_camera* cam = nullptr;
    char why[320];
    ASSERT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), 0) << why;
    ASSERT_EQ(vc_camera_start(cam), 0) << vc_camera_last_error(cam);
    cams.push_back(cam);
  }
  for (int round = 0; round < 60; round++) {
    for (vc_camera* cam : cams) {
      vc_frame f;
      ASSERT_EQ(vc_camera_capture(cam, 2000, &f), 0) << vc_camera_last_error(cam);
      vc_camera_release(cam, &f);
    }
  }
  for (vc_camera* cam : cams) {
    Summary s = stream(cam, 30);
    EXPECT_TRUE(s.increasing);
    vc_camera_free(cam);
  }
}

}  // namespace
