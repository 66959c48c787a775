// The sim backend: frames equal the virtual rig's own renders (free-running, triggered, background),
// scenes are shared per spec or borrowed, and bad specs are clear errors.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <opencv2/core.hpp>
#include <string>

#include "voxcap/edge/camera.h"
#include "voxcap/edge/camera_sim.h"
#include "voxcap/sim/scene.hpp"

namespace {

constexpr const char* kSpec = "motion=wave,cameras=2,size=160x120,seed=3,noise=2";

vc::sim::SceneOptions spec_options() {
  vc::sim::SceneOptions o;
  o.motion.source = "wave";
  o.rig.cameras = 2;
  o.rig.width = 160;
  o.rig.height = 120;
  o.seed = 3;
  o.noise_sigma = 2;
  return o;
}

// True when frame f holds exactly `img` (CV_8UC3 RGB).
::testing::AssertionResult same_pixels(const vc_frame& f, const cv::Mat& img) {
  if (img.cols != f.width || img.rows != f.height) return ::testing::AssertionFailure() << "size differs";
  for (int y = 0; y < f.height; y++)
    if (std::memcmp(f.rgb + (size_t)y * f.stride, img.ptr(y), (size_t)f.width * 3) != 0)
      return ::testing::AssertionFailure() << "row " << y << " differs";
  return ::testing::AssertionSuccess();
}

class SimBackend : public ::testing::Test {
 protected:
  void TearDown() override {
    vc_camera_free(cam_);
    vc_camera_free(cam2_);
  }
  int open(vc_camera** cam, const vc_camera_config& cfg) {
    char why[320];
    int rc = vc_camera_open(&cfg, cam, why, sizeof why);
    why_ = why;
    return rc;
  }
  vc_camera_config base(int index) {
    vc_camera_config cfg;
    vc_camera_config_init(&cfg);
    cfg.backend = "sim";
    cfg.device = kSpec;
    cfg.index = index;
    return cfg;
  }
  vc_camera* cam_ = nullptr;
  vc_camera* cam2_ = nullptr;
  std::string why_;
};

TEST_F(SimBackend, FreeRunningFramesAreTheScenesRenders) {
  ASSERT_EQ(open(&cam_, base(1)), 0) << why_;
  vc_camera_info info;
  vc_camera_get_info(cam_, &info);
  EXPECT_EQ(info.width, 160);
  EXPECT_EQ(info.height, 120);
  EXPECT_EQ(info.fps_num, 60000u);
  EXPECT_EQ(info.fps_den, 1000u);
  vc::sim::Scene scene(spec_options());
  ASSERT_EQ(vc_camera_start(cam_), 0);
  uint64_t t_prev = 0;
  for (int n = 0; n < 3; n++) {
    vc_frame f;
    ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0) << vc_camera_last_error(cam_);
    cv::Mat want;
    scene.render(n, 1, want);
    EXPECT_TRUE(same_pixels(f, want)) << "frame " << n;
    EXPECT_EQ(f.index, (uint64_t)n);
    if (n > 0) {
      EXPECT_EQ(f.t_ns - t_prev, 16666667u);
    }
    t_prev = f.t_ns;
    vc_camera_release(cam_, &f);
  }
}

TEST_F(SimBackend, TriggeredFrameIsThePulsesSimulatorFrame) {
  vc_camera_config cfg = base(0);
  cfg.external_trigger = true;
  cfg.options = "seq_base=1000";
  cfg.trigger_latency_ns = 2000000;
  ASSERT_EQ(open(&cam_, cfg), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 1075, 9000000000ull), 0);
  vc_frame f;
  ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0) << vc_camera_last_error(cam_);
  EXPECT_EQ(f.index, 75u);
  EXPECT_EQ(f.t_ns, 9002000000ull);
  vc::sim::Scene scene(spec_options());
  cv::Mat want;
  scene.render(75, 0, want);
  EXPECT_TRUE(same_pixels(f, want));
  vc_camera_release(cam_, &f);
}

TEST_F(SimBackend, BackgroundAndBorrowedScene) {
  vc::sim::Scene scene(spec_options());
  vc_camera_config cfg = base(0);
  cfg.device = nullptr;
  cfg.options = "scene=empty";
  char why[320];
  ASSERT_EQ(vc_camera_open_sim(&cfg, &scene, &cam_, why, sizeof why), 0) << why;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  for (int i = 0; i < 2; i++) {
    vc_frame f;
    ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0);
    cv::Mat want;
    scene.render_background(0, i, want);
    EXPECT_TRUE(same_pixels(f, want)) << "background " << i;
    vc_camera_release(cam_, &f);
  }
}

TEST_F(SimBackend, RewindRendersTheEmptyRoomThenThePulsesFrame) {
  vc_camera_config cfg = base(1);
  cfg.external_trigger = true;
  ASSERT_EQ(open(&cam_, cfg), 0) << why_;
  EXPECT_EQ(vc_camera_caps(cam_), VC_CAMERA_CAP_REWIND | VC_CAMERA_CAP_SOFT_TRIGGER);
  vc::sim::Scene scene(spec_options());
  ASSERT_EQ(vc_camera_rewind(cam_, 500, VC_CAMERA_SCENE_EMPTY), 0);
  ASSERT_EQ(vc_camera_start(cam_), 0);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 501, 1000), 0);
  vc_frame f;
  ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0) << vc_camera_last_error(cam_);
  cv::Mat want;
  scene.render_background(1, 1, want);
  EXPECT_TRUE(same_pixels(f, want));
  vc_camera_release(cam_, &f);
  ASSERT_EQ(vc_camera_stop(cam_), 0);
  ASSERT_EQ(vc_camera_rewind(cam_, 2000, VC_CAMERA_SCENE_LIVE), 0);
  ASSERT_EQ(vc_camera_start(cam_), 0);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 2010, 2000), 0);
  ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0) << vc_camera_last_error(cam_);
  EXPECT_EQ(f.index, 10u);
  scene.render(10, 1, want);
  EXPECT_TRUE(same_pixels(f, want));
  vc_camera_release(cam_, &f);
}

TEST_F(SimBackend, TwoCamerasOfOneSpecRenderTheirOwnViews) {
  ASSERT_EQ(open(&cam_, base(0)), 0) << why_;
  ASSERT_EQ(open(&cam2_, base(1)), 0) << why_;
  vc_camera_info a, b;
  vc_camera_get_info(cam_, &a);
  vc_camera_get_info(cam2_, &b);
  EXPECT_STREQ(a.driver, "sim wave cam 0/2");
  EXPECT_STREQ(b.driver, "sim wave cam 1/2");
  vc::sim::Scene scene(spec_options());
  ASSERT_EQ(vc_camera_start(cam_), 0);
  ASSERT_EQ(vc_camera_start(cam2_), 0);
  vc_frame f0, f1;
  ASSERT_EQ(vc_camera_capture(cam_, 1000, &f0), 0);
  ASSERT_EQ(vc_camera_capture(cam2_, 1000, &f1), 0);
  cv::Mat v0, v1;
  scene.render(0, 0, v0);
  scene.render(0, 1, v1);
  EXPECT_TRUE(same_pixels(f0, v0));
  EXPECT_TRUE(same_pixels(f1, v1));
  EXPECT_FALSE(same_pixels(f0, v1));
  vc_camera_release(cam_, &f0);
  vc_camera_release(cam2_, &f1);
}

TEST_F(SimBackend, AppearanceAndRoomOfTheSpecAreRendered) {
  // What the emulated rig passes so that its edges render what its scorer renders.
  vc_camera_config cfg = base(1);
  const std::string spec = std::string(kSpec) + ",appearance=olive,room=camouflage";
  cfg.device = spec.c_str();
  ASSERT_EQ(open(&cam_, cfg), 0) << why_;
  vc::sim::SceneOptions o = spec_options();
  o.appearance = "olive";
  o.room = "camouflage";
  vc::sim::Scene scene(o), plain(spec_options());
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame f;
  ASSERT_EQ(vc_camera_capture(cam_, 1000, &f), 0) << vc_camera_last_error(cam_);
  cv::Mat want, other;
  scene.render(0, 1, want);
  plain.render(0, 1, other);
  EXPECT_TRUE(same_pixels(f, want));
  EXPECT_FALSE(same_pixels(f, other));
  vc_camera_release(cam_, &f);
  cfg.device = "motion=wave,size=160x120,room=cave";
  EXPECT_EQ(open(&cam2_, cfg), -EINVAL);
  EXPECT_NE(why_.find("unknown room 'cave' (known: default, camouflage)"), std::string::npos) << why_;
}

TEST_F(SimBackend, ClearErrors) {
  vc_camera_config cfg = base(5);
  EXPECT_EQ(open(&cam_, cfg), -ENOENT);
  EXPECT_EQ(why_, std::string("sim: ") + kSpec + ": no camera 5 in the scene (it has 2)");
  cfg = base(0);
  cfg.width = 640;
  cfg.height = 480;
  EXPECT_EQ(open(&cam_, cfg), -ENOTSUP);
  EXPECT_EQ(why_, std::string("sim: ") + kSpec + ": size 640x480 not supported (scene camera 0 is 160x120)");
  cfg = base(0);
  cfg.device = "motion=wave,colour=red";
  EXPECT_EQ(open(&cam_, cfg), -EINVAL);
  EXPECT_NE(why_.find("scene spec: unknown key or bad value 'colour=red'"), std::string::npos) << why_;
  cfg.device = "motion=moonwalk,size=160x120";
  EXPECT_EQ(open(&cam_, cfg), -EINVAL);
  EXPECT_NE(why_.find("moonwalk"), std::string::npos) << why_;
  EXPECT_EQ(cam_, nullptr);
}

}  // namespace
