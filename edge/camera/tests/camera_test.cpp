// The common camera layer (state, held buffers, stats, errors) through a scripted fake backend, and
// the factory.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include "voxcap/edge/camera_backend.h"

namespace {

struct Script {
  int open_rc = 0;
  std::vector<uint64_t> sequences;  // one capture each; exhausted -> -ETIMEDOUT
  size_t next = 0;
  int started = 0, stopped = 0, freed = 0;
};
Script* g_script = nullptr;

int fake_open(vc_camera* cam, const vc_camera_config*, vc_camera_info* info, void** priv) {
  if (g_script->open_rc) return vc_camera_set_error(cam, g_script->open_rc, "scripted failure %d", 42);
  info->width = 4;
  info->height = 2;
  *priv = g_script;
  return 0;
}
int fake_start(vc_camera*, void* p) {
  static_cast<Script*>(p)->started++;
  return 0;
}
int fake_capture(vc_camera* cam, void* p, int timeout_ms, uint8_t* rgb, size_t stride, vc_frame* meta) {
  auto* s = static_cast<Script*>(p);
  if (s->next == s->sequences.size())
    return vc_camera_set_error(cam, -ETIMEDOUT, "camera stopped delivering: no frame within %d ms",
                               timeout_ms);
  for (int y = 0; y < 2; y++) memset(rgb + y * stride, (int)s->next, 12);
  meta->sequence = s->sequences[s->next++];
  meta->t_ns = 1000 * meta->sequence;
  meta->flags = VC_FRAME_TS_DRIVER;
  return 0;
}
int fake_stop(vc_camera*, void* p) {
  static_cast<Script*>(p)->stopped++;
  return 0;
}
void fake_free(void* p) {
  if (p) static_cast<Script*>(p)->freed++;
}
const vc_camera_backend kFake = {"fake",    fake_open, fake_start, fake_capture, fake_stop,
                                 fake_free, nullptr,   nullptr,    nullptr};

class CommonLayer : public ::testing::Test {
 protected:
  void SetUp() override {
    g_script = &script_;
    vc_camera_config_init(&cfg_);
    cfg_.device = "dev0";
  }
  Script script_;
  vc_camera_config cfg_;
};

TEST_F(CommonLayer, CapturesIntoHeldBuffersAndCountsDrops) {
  script_.sequences = {10, 11, 14, 15};
  vc_camera* cam = nullptr;
  char why[128];
  ASSERT_EQ(vc_camera_open_backend(&kFake, &cfg_, &cam, why, sizeof why), 0) << why;
  vc_camera_info info;
  vc_camera_get_info(cam, &info);
  EXPECT_STREQ(info.backend, "fake");
  EXPECT_STREQ(info.device, "dev0");
  vc_frame f;
  EXPECT_EQ(vc_camera_capture(cam, 10, &f), -EINVAL);  // not started
  EXPECT_STREQ(vc_camera_last_error(cam), "fake: dev0: capture before start (or after stop)");
  ASSERT_EQ(vc_camera_start(cam), 0);
  vc_frame a, b, c;
  ASSERT_EQ(vc_camera_capture(cam, 10, &a), 0);
  ASSERT_EQ(vc_camera_capture(cam, 10, &b), 0);
  EXPECT_NE(a.rgb, b.rgb);
  EXPECT_EQ(a.width, 4);
  EXPECT_GE(a.stride, 12u);
  EXPECT_EQ(a.rgb[0], 0);
  EXPECT_EQ(b.rgb[a.stride], 1);
  EXPECT_EQ(vc_camera_capture(cam, 10, &c), -EBUSY);  // 2 held frames by default
  EXPECT_STREQ(vc_camera_last_error(cam), "fake: dev0: all 2 frame buffers are held: release frames first");
  ASSERT_EQ(vc_camera_release(cam, &a), 0);
  EXPECT_EQ(a.rgb, nullptr);
  EXPECT_EQ(vc_camera_release(cam, &a), -EINVAL);  // twice
  ASSERT_EQ(vc_camera_capture(cam, 10, &c), 0);
  EXPECT_EQ(c.sequence, 14u);
  vc_camera_release(cam, &b);
  vc_camera_release(cam, &c);
  ASSERT_EQ(vc_camera_capture(cam, 10, &c), 0);
  vc_camera_release(cam, &c);
  EXPECT_EQ(vc_camera_capture(cam, 25, &c), -ETIMEDOUT);
  EXPECT_STREQ(vc_camera_last_error(cam), "fake: dev0: camera stopped delivering: no frame within 25 ms");
  EXPECT_EQ(vc_camera_last_errno(cam), -ETIMEDOUT);
  vc_camera_stats st;
  vc_camera_get_stats(cam, &st);
  EXPECT_EQ(st.frames, 4u);
  EXPECT_EQ(st.dropped, 2u);  // 12 and 13
  EXPECT_EQ(st.timeouts, 1u);
  EXPECT_EQ(vc_camera_soft_trigger(cam, 1, 2), -ENOTSUP);
  EXPECT_EQ(vc_camera_caps(cam), 0u);  // a real camera: triggered by its wire, sees the room
  EXPECT_EQ(vc_camera_rewind(cam, 0, VC_CAMERA_SCENE_EMPTY), -ENOTSUP);
  EXPECT_STREQ(vc_camera_last_error(cam), "fake: dev0: cannot rewind: a real camera sees the room as it is");
  vc_camera_free(cam);  // stops
  EXPECT_EQ(script_.stopped, 1);
  EXPECT_EQ(script_.freed, 1);
}

TEST_F(CommonLayer, OpenFailureFillsWhyAndLeavesNothing) {
  script_.open_rc = -ENOENT;
  vc_camera* cam = reinterpret_cast<vc_camera*>(0x1);
  char why[128];
  EXPECT_EQ(vc_camera_open_backend(&kFake, &cfg_, &cam, why, sizeof why), -ENOENT);
  EXPECT_EQ(cam, nullptr);
  EXPECT_STREQ(why, "fake: dev0: scripted failure 42");
}

TEST_F(CommonLayer, ConfigIsChecked) {
  vc_camera* cam = nullptr;
  char why[128];
  cfg_.width = 640;  // no height
  EXPECT_EQ(vc_camera_open_backend(&kFake, &cfg_, &cam, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "camera config: width and height must both be positive (or both 0 for the default)");
  cfg_.height = 480;
  cfg_.held_frames = 17;
  EXPECT_EQ(vc_camera_open_backend(&kFake, &cfg_, &cam, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "camera config: held_frames must be at most 16");
  cfg_.held_frames = 3;
  cfg_.n_controls = 1;
  EXPECT_EQ(vc_camera_open_backend(&kFake, &cfg_, &cam, why, sizeof why), -EINVAL);
  EXPECT_EQ(script_.freed, 0);
}

TEST(CameraFactory, SelectsByNameAndRejectsUnknown) {
  const char* const* names = vc_camera_backend_names();
  std::vector<std::string> got;
  for (; *names; names++) got.emplace_back(*names);
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  vc_camera* cam = nullptr;
  char why[160];
  if (VC_TEST_HAVE_SIM) {
    EXPECT_EQ(got, (std::vector<std::string>{"v4l2", "libcamera", "file", "sim"}));
  } else {  // built with -DVOXCAP_SIM=OFF
    EXPECT_EQ(got, (std::vector<std::string>{"v4l2", "libcamera", "file"}));
    cfg.backend = "sim";
    EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -ENOTSUP);
    EXPECT_STREQ(why,
                 "camera config: sim backend not built in (this voxcap-edge was built with -DVOXCAP_SIM=OFF; "
                 "use v4l2, libcamera or file)");
    EXPECT_EQ(cam, nullptr);
    cfg.backend = nullptr;
  }
  EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "camera config: no backend given (one of v4l2, libcamera, file, sim)");
  cfg.backend = "gstreamer";
  EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "camera config: unknown backend 'gstreamer' (one of v4l2, libcamera, file, sim)");
  cfg.backend = "v4l2";
  cfg.device = "/dev/video-does-not-exist";
  EXPECT_EQ(vc_camera_open(&cfg, &cam, why, sizeof why), -ENOENT);
  EXPECT_EQ(cam, nullptr);
}

TEST(PixfmtNames, RoundTrip) {
  for (vc_pixfmt f : {VC_PIXFMT_RGB24, VC_PIXFMT_BGR24, VC_PIXFMT_YUYV, VC_PIXFMT_UYVY, VC_PIXFMT_GREY}) {
    vc_pixfmt back;
    ASSERT_EQ(vc_pixfmt_from_name(vc_pixfmt_name(f), &back), 0);
    EXPECT_EQ(back, f);
  }
  vc_pixfmt g;
  EXPECT_EQ(vc_pixfmt_from_name("GRAY", &g), 0);
  EXPECT_EQ(g, VC_PIXFMT_GREY);
  EXPECT_EQ(vc_pixfmt_from_name("mjpeg", &g), -EINVAL);
  EXPECT_EQ(vc_pixfmt_name((vc_pixfmt)99), nullptr);
}

}  // namespace
