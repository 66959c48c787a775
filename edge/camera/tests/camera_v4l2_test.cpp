// The v4l2 backend natively: error paths that need no V4L2 device, and its pure helpers. Streaming
// against a real driver is tests/vm (vivid under qemu).
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <cerrno>
#include <cstdio>
#include <string>

#include "v4l2_util.h"
#include "voxcap/edge/camera_backend.h"

namespace {

std::string open_v4l2(const char* dev, int* rc) {
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  cfg.backend = "v4l2";
  cfg.device = dev;
  vc_camera* cam = nullptr;
  char why[256];
  *rc = vc_camera_open(&cfg, &cam, why, sizeof why);
  EXPECT_EQ(cam, nullptr);
  vc_camera_free(cam);
  return why;
}

TEST(V4l2Backend, MissingDeviceIsAClearError) {
  int rc = 0;
  EXPECT_EQ(open_v4l2("/dev/video-does-not-exist", &rc),
            "v4l2: /dev/video-does-not-exist: cannot open: No such file or directory");
  EXPECT_EQ(rc, -ENOENT);
}

TEST(V4l2Backend, NonV4l2DevicesAreRejected) {
  int rc = 0;
  EXPECT_EQ(open_v4l2("/dev/null", &rc), "v4l2: /dev/null: not a V4L2 device (VIDIOC_QUERYCAP: Inappropriate ioctl for device)");
  EXPECT_EQ(rc, -ENODEV);
  std::string file = std::string(VOXCAP_BINARY_DIR) + "/edgeio_not_a_device";
  FILE* f = fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  fclose(f);
  EXPECT_EQ(open_v4l2(file.c_str(), &rc), "v4l2: " + file + ": not a V4L2 device (not a character device)");
  EXPECT_EQ(rc, -ENODEV);
  remove(file.c_str());
}

TEST(V4l2Backend, NoDeviceGiven) {
  int rc = 0;
  EXPECT_EQ(open_v4l2(nullptr, &rc), "v4l2: no device given (e.g. /dev/video0)");
  EXPECT_EQ(rc, -EINVAL);
}

TEST(V4l2Util, FourccMapping) {
  EXPECT_EQ(vc_v4l2_fourcc_from_pixfmt(VC_PIXFMT_YUYV), (uint32_t)V4L2_PIX_FMT_YUYV);
  EXPECT_EQ(vc_v4l2_fourcc_from_pixfmt(VC_PIXFMT_GREY), (uint32_t)V4L2_PIX_FMT_GREY);
  EXPECT_EQ(vc_v4l2_fourcc_from_pixfmt(VC_PIXFMT_RGB24), (uint32_t)V4L2_PIX_FMT_RGB24);
  EXPECT_EQ(vc_v4l2_fourcc_from_pixfmt(VC_PIXFMT_DEFAULT), 0u);
  for (vc_pixfmt f : {VC_PIXFMT_RGB24, VC_PIXFMT_BGR24, VC_PIXFMT_YUYV, VC_PIXFMT_UYVY, VC_PIXFMT_GREY})
    EXPECT_EQ(vc_v4l2_pixfmt_from_fourcc(vc_v4l2_fourcc_from_pixfmt(f)), f);
  EXPECT_EQ(vc_v4l2_pixfmt_from_fourcc(V4L2_PIX_FMT_MJPEG), VC_PIXFMT_DEFAULT);
}

TEST(V4l2Util, UnsupportedFormatMessageListsWhatIsOffered) {
  const uint32_t offered[] = {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_Y10};
  EXPECT_TRUE(vc_v4l2_format_offered(V4L2_PIX_FMT_YUYV, offered, 3));
  EXPECT_FALSE(vc_v4l2_format_offered(V4L2_PIX_FMT_RGB24, offered, 3));
  EXPECT_FALSE(vc_v4l2_format_offered(0, offered, 3));
  char list[64];
  vc_v4l2_format_list(offered, 3, list, sizeof list);
  EXPECT_STREQ(list, "MJPG, YUYV, Y10");
  vc_v4l2_format_list(offered, 0, list, sizeof list);
  EXPECT_STREQ(list, "none");
  char tiny[10];
  vc_v4l2_format_list(offered, 3, tiny, sizeof tiny);
  EXPECT_STREQ(tiny, "MJPG, ...");
}

TEST(V4l2Util, ControlNamesAsV4l2CtlSpellsThem) {
  char k[64];
  vc_v4l2_control_key("Percentage of Dropped Buffers", k, sizeof k);
  EXPECT_STREQ(k, "percentage_of_dropped_buffers");
  vc_v4l2_control_key("Inject V4L2_BUF_FLAG_ERROR", k, sizeof k);
  EXPECT_STREQ(k, "inject_v4l2_buf_flag_error");
  vc_v4l2_control_key("  Exposure, Time (Absolute) ", k, sizeof k);
  EXPECT_STREQ(k, "exposure_time_absolute");
  vc_v4l2_control_key("trigger_mode", k, sizeof k);
  EXPECT_STREQ(k, "trigger_mode");
}

TEST(V4l2Util, ColorimetryDefaultsResolve) {
  vc_yuv_matrix m;
  bool full;
  vc_v4l2_colorimetry(V4L2_COLORSPACE_SMPTE170M, V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT, &m, &full);
  EXPECT_EQ(m, VC_YUV_BT601);
  EXPECT_FALSE(full);
  vc_v4l2_colorimetry(V4L2_COLORSPACE_REC709, V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT, &m, &full);
  EXPECT_EQ(m, VC_YUV_BT709);
  EXPECT_FALSE(full);
  vc_v4l2_colorimetry(V4L2_COLORSPACE_JPEG, V4L2_YCBCR_ENC_DEFAULT, V4L2_QUANTIZATION_DEFAULT, &m, &full);
  EXPECT_EQ(m, VC_YUV_BT601);
  EXPECT_TRUE(full);
  vc_v4l2_colorimetry(V4L2_COLORSPACE_SRGB, V4L2_YCBCR_ENC_709, V4L2_QUANTIZATION_FULL_RANGE, &m, &full);
  EXPECT_EQ(m, VC_YUV_BT709);
  EXPECT_TRUE(full);
}

}  // namespace
