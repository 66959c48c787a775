// The libcamera backend natively: this machine has no camera, so the camera manager must say so
// clearly; plus the shim's pure helpers.
#include <gtest/gtest.h>
#include <libcamera/formats.h>

#include <cerrno>
#include <string>

#include "libcamera_util.hpp"
#include "voxcap/edge/camera.h"

namespace {

TEST(LibcameraBackend, NoCameraGivesAClearError) {
  // The CameraManager really starts and enumerates; a machine with a camera has nothing to assert here.
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  cfg.backend = "libcamera";
  cfg.device = "0";
  vc_camera* cam = nullptr;
  char why[256];
  int rc = vc_camera_open(&cfg, &cam, why, sizeof why);
  if (rc == 0) {
    vc_camera_free(cam);
    GTEST_SKIP() << "this machine has a libcamera camera: the no-camera path cannot be exercised";
  }
  EXPECT_EQ(rc, -ENOENT);
  EXPECT_STREQ(why, "libcamera: 0: no cameras found");
  EXPECT_EQ(cam, nullptr);
  // the process-wide manager is released and re-created cleanly
  EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -ENOENT);
}

TEST(LibcameraBackend, TriggeredSensorNeedsAFixedExposure) {
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  cfg.backend = "libcamera";
  cfg.external_trigger = true;
  vc_camera* cam = nullptr;
  char why[256];
  EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "libcamera: an externally triggered sensor needs a fixed exposure_us");
}

TEST(LibcameraUtil, LayoutsFollowDrmNaming) {
  namespace f = libcamera::formats;
  using vc::edgecam::Layout;
  EXPECT_EQ(vc::edgecam::layout_of(f::BGR888), Layout::kRgb);  // R,G,B bytes in memory
  EXPECT_EQ(vc::edgecam::layout_of(f::RGB888), Layout::kBgr);
  EXPECT_EQ(vc::edgecam::layout_of(f::XBGR8888), Layout::kRgbx);
  EXPECT_EQ(vc::edgecam::layout_of(f::XRGB8888), Layout::kBgrx);
  EXPECT_EQ(vc::edgecam::layout_of(f::YUYV), Layout::kYuyv);
  EXPECT_EQ(vc::edgecam::layout_of(f::SBGGR10), Layout::kUnsupported);
  EXPECT_EQ(vc::edgecam::preferred_formats().front(), f::BGR888);
  EXPECT_EQ(vc::edgecam::pixfmt_of(Layout::kBgr), VC_PIXFMT_BGR24);
}

TEST(LibcameraUtil, ConvertsEachLayoutToRgb) {
  using vc::edgecam::Layout;
  const uint8_t bgr[3] = {3, 2, 1}, rgb[3] = {1, 2, 3}, bgrx[4] = {3, 2, 1, 0}, rgbx[4] = {1, 2, 3, 0};
  uint8_t out[3];
  for (auto [layout, src, stride] : {std::tuple{Layout::kRgb, rgb, 3}, std::tuple{Layout::kBgr, bgr, 3},
                                     std::tuple{Layout::kRgbx, rgbx, 4}, std::tuple{Layout::kBgrx, bgrx, 4}}) {
    ASSERT_EQ(vc::edgecam::convert(layout, src, (size_t)stride, out, 3, 1, 1, nullptr), 0);
    EXPECT_EQ(out[0], 1);
    EXPECT_EQ(out[1], 2);
    EXPECT_EQ(out[2], 3);
  }
  EXPECT_EQ(vc::edgecam::convert(Layout::kUnsupported, rgb, 3, out, 3, 1, 1, nullptr), -EINVAL);
}

TEST(LibcameraUtil, FrameDuration) {
  EXPECT_EQ(vc::edgecam::frame_duration_us(60, 1), 16667);
  EXPECT_EQ(vc::edgecam::frame_duration_us(30000, 1001), 33367);
  EXPECT_EQ(vc::edgecam::frame_duration_us(120, 0), 8333);
  EXPECT_EQ(vc::edgecam::frame_duration_us(0, 1), 0);
}

TEST(LibcameraUtil, PickCamera) {
  const std::vector<std::string> ids = {"/base/imx296@1a", "/base/imx296@2b"};
  std::string why;
  EXPECT_EQ(vc::edgecam::pick_camera(ids, "", &why), 0);
  EXPECT_EQ(vc::edgecam::pick_camera(ids, "1", &why), 1);
  EXPECT_EQ(vc::edgecam::pick_camera(ids, "/base/imx296@2b", &why), 1);
  EXPECT_EQ(vc::edgecam::pick_camera(ids, "2", &why), -1);
  EXPECT_EQ(why, "camera index 2 out of range (cameras: 0=/base/imx296@1a, 1=/base/imx296@2b)");
  EXPECT_EQ(vc::edgecam::pick_camera(ids, "imx477", &why), -1);
  EXPECT_EQ(why, "no camera 'imx477' (cameras: 0=/base/imx296@1a, 1=/base/imx296@2b)");
  EXPECT_EQ(vc::edgecam::pick_camera({}, "0", &why), -1);
  EXPECT_EQ(why, "no cameras found");
}

}  // namespace
