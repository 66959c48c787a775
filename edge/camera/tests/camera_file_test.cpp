// The file backend against a small `voxcap sim`-style folder written by the test.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "voxcap/edge/camera.h"

namespace fs = std::filesystem;

namespace {

constexpr int kW = 32, kH = 24;

// Frame n of camera k: a flat colour whose RGB encodes both, plus a red pixel at (1,0).
cv::Vec3b colour(int cam, int n) {
  return {(uint8_t)(10 * n), (uint8_t)(100 + cam), (uint8_t)(200 - n)};
}

class FileBackend : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(VOXCAP_BINARY_DIR) / "edgeio_file_backend" /
           ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    for (int cam = 0; cam < 2; cam++) {
      fs::create_directories(dir_ / ("cam" + std::to_string(cam)));
      fs::create_directories(dir_ / "background" / ("cam" + std::to_string(cam)));
      for (int n = 0; n < 5; n++) write(dir_ / ("cam" + std::to_string(cam)) / name(n), colour(cam, n));
      for (int i = 0; i < 2; i++)
        write(dir_ / "background" / ("cam" + std::to_string(cam)) / name(i), {1, 2, 3});
    }
    fs::path noise = dir_ / "cam0" / "notes.txt";
    FILE* f = fopen(noise.c_str(), "w");
    fclose(f);
    vc_camera_config_init(&cfg_);
    cfg_.backend = "file";
    dev_ = dir_.string();
    cfg_.device = dev_.c_str();
  }
  void TearDown() override {
    vc_camera_free(cam_);
    fs::remove_all(dir_);
  }
  static std::string name(int n) {
    char b[32];
    snprintf(b, sizeof b, "%06d.png", n);
    return b;
  }
  static void write(const fs::path& p, cv::Vec3b rgb) {
    cv::Mat img(kH, kW, CV_8UC3, cv::Scalar(rgb[2], rgb[1], rgb[0]));  // imwrite takes BGR
    img.at<cv::Vec3b>(0, 1) = cv::Vec3b(0, 0, 255);                    // a red pixel
    ASSERT_TRUE(cv::imwrite(p.string(), img));
  }
  int open() {
    char why[256];
    int rc = vc_camera_open(&cfg_, &cam_, why, sizeof why);
    why_ = why;
    return rc;
  }
  fs::path dir_;
  std::string dev_, why_;
  vc_camera_config cfg_;
  vc_camera* cam_ = nullptr;
};

TEST_F(FileBackend, ReplaysFramesInRgbOrderWithSynthesisedTimes) {
  cfg_.index = 1;
  cfg_.fps_num = 50;
  ASSERT_EQ(open(), 0) << why_;
  vc_camera_info info;
  vc_camera_get_info(cam_, &info);
  EXPECT_EQ(info.width, kW);
  EXPECT_EQ(info.height, kH);
  ASSERT_EQ(vc_camera_start(cam_), 0);
  uint64_t t_prev = 0;
  for (int n = 0; n < 5; n++) {
    vc_frame f;
    ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0) << vc_camera_last_error(cam_);
    EXPECT_EQ(f.index, (uint64_t)n);
    EXPECT_EQ(f.sequence, (uint64_t)n);
    EXPECT_EQ(f.flags, VC_FRAME_TS_SYNTH);
    const uint8_t* px = f.rgb + f.stride * 5 + 3 * 7;
    cv::Vec3b want = colour(1, n);
    EXPECT_EQ(px[0], want[0]);
    EXPECT_EQ(px[1], want[1]);
    EXPECT_EQ(px[2], want[2]);
    EXPECT_EQ(f.rgb[3], 255);  // the red pixel is red: R first
    EXPECT_EQ(f.rgb[4], 0);
    EXPECT_EQ(f.rgb[5], 0);
    if (n > 0) {
      EXPECT_EQ(f.t_ns - t_prev, 20000000u);  // 50 fps
    }
    t_prev = f.t_ns;
    vc_camera_release(cam_, &f);
  }
  vc_frame f;
  EXPECT_EQ(vc_camera_capture(cam_, 100, &f), -ENODATA);
  EXPECT_EQ(std::string(vc_camera_last_error(cam_)),
            "file: " + dev_ + ": end of the sequence (5 frames, asked for frame 5)");
}

TEST_F(FileBackend, LoopsWhenAsked) {
  cfg_.options = "loop=1";
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  for (int n = 0; n < 7; n++) {
    vc_frame f;
    ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
    EXPECT_EQ(f.index, (uint64_t)(n % 5));
    EXPECT_EQ(f.sequence, (uint64_t)n);
    vc_camera_release(cam_, &f);
  }
}

TEST_F(FileBackend, ReadsTheBackgroundFolder) {
  cfg_.options = "scene=empty";
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame f;
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
  EXPECT_EQ(f.rgb[f.stride + 0], 1);
  EXPECT_EQ(f.rgb[f.stride + 2], 3);
  vc_camera_release(cam_, &f);
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
  vc_camera_release(cam_, &f);
  EXPECT_EQ(vc_camera_capture(cam_, 100, &f), -ENODATA);
}

TEST_F(FileBackend, TriggeredModeShowsThePulsesFrame) {
  cfg_.external_trigger = true;
  cfg_.options = "seq_base=100";
  cfg_.trigger_latency_ns = 3000000;
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame f;
  EXPECT_EQ(vc_camera_capture(cam_, 20, &f), -ETIMEDOUT);
  EXPECT_EQ(std::string(vc_camera_last_error(cam_)),
            "file: " + dev_ + ": camera stopped delivering: no trigger within 20 ms");
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 103, 5000000000ull), 0);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 104, 5016666666ull), 0);
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
  EXPECT_EQ(f.index, 3u);
  EXPECT_EQ(f.t_ns, 5003000000ull);
  EXPECT_EQ(f.rgb[f.stride], colour(0, 3)[0]);
  vc_camera_release(cam_, &f);
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
  EXPECT_EQ(f.index, 4u);
  EXPECT_EQ(f.sequence, 1u);
  vc_camera_release(cam_, &f);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 105, 5033333333ull), 0);  // beyond the 5 frames
  EXPECT_EQ(vc_camera_capture(cam_, 100, &f), -ENODATA);
}

TEST_F(FileBackend, FreeRunningCameraRefusesSoftTriggers) {
  ASSERT_EQ(open(), 0) << why_;
  EXPECT_EQ(vc_camera_soft_trigger(cam_, 1, 1), -EINVAL);
}

TEST_F(FileBackend, PacedCaptureTimesOutBeforeTheFrameIsDue) {
  cfg_.options = "pace=1";
  cfg_.fps_num = 1;  // one frame a second
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame f;
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);  // frame 0 is due at start
  vc_camera_release(cam_, &f);
  EXPECT_EQ(vc_camera_capture(cam_, 10, &f), -ETIMEDOUT);
}

TEST_F(FileBackend, CapabilitiesFollowTheTriggerMode) {
  ASSERT_EQ(open(), 0) << why_;
  EXPECT_EQ(vc_camera_caps(cam_), VC_CAMERA_CAP_REWIND);
  vc_camera_free(cam_);
  cam_ = nullptr;
  cfg_.external_trigger = true;
  ASSERT_EQ(open(), 0) << why_;
  EXPECT_EQ(vc_camera_caps(cam_), VC_CAMERA_CAP_REWIND | VC_CAMERA_CAP_SOFT_TRIGGER);
}

TEST_F(FileBackend, RewindSwitchesToTheLoopingBackgroundAndBackToThePulsesFrame) {
  cfg_.external_trigger = true;
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  EXPECT_EQ(vc_camera_rewind(cam_, 0, VC_CAMERA_SCENE_EMPTY), -EBUSY);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 9, 1000), 0);  // dropped by the rewind below
  ASSERT_EQ(vc_camera_stop(cam_), 0);
  ASSERT_EQ(vc_camera_rewind(cam_, 50, VC_CAMERA_SCENE_EMPTY), 0) << vc_camera_last_error(cam_);
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame f;
  for (uint64_t seq = 50; seq < 53; seq++) {  // two background frames, looping
    ASSERT_EQ(vc_camera_soft_trigger(cam_, seq, 2000 + seq), 0);
    ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0) << vc_camera_last_error(cam_);
    EXPECT_EQ(f.index, (seq - 50) % 2);
    EXPECT_EQ(f.rgb[f.stride + 0], 1);
    vc_camera_release(cam_, &f);
  }
  ASSERT_EQ(vc_camera_stop(cam_), 0);
  ASSERT_EQ(vc_camera_rewind(cam_, 200, VC_CAMERA_SCENE_LIVE), 0);
  ASSERT_EQ(vc_camera_start(cam_), 0);
  ASSERT_EQ(vc_camera_soft_trigger(cam_, 202, 3000), 0);
  ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0);
  EXPECT_EQ(f.index, 2u);
  EXPECT_EQ(f.sequence, 0u);
  EXPECT_EQ(f.rgb[f.stride], colour(0, 2)[0]);
  vc_camera_release(cam_, &f);
}

TEST_F(FileBackend, RewindToAMissingBackgroundIsAClearError) {
  fs::remove_all(dir_ / "background");
  ASSERT_EQ(open(), 0) << why_;
  EXPECT_EQ(vc_camera_rewind(cam_, 0, VC_CAMERA_SCENE_EMPTY), -ENOENT);
  EXPECT_EQ(
      std::string(vc_camera_last_error(cam_)),
      "file: " + dev_ + ": no folder " + dev_ + "/background/cam0 (is this a `voxcap sim --out` folder?)");
}

TEST_F(FileBackend, UnknownOptionsAreErrors) {
  cfg_.options = "loop=1,colour=red";
  EXPECT_EQ(open(), -EINVAL);
  EXPECT_EQ(why_, "file: " + dev_ + ": unknown option 'colour' (options: pace, loop, scene, seq_base)");
  cfg_.options = "scene=full";
  EXPECT_EQ(open(), -EINVAL);
  EXPECT_EQ(why_, "file: " + dev_ + ": option scene must be live or empty");
}

TEST_F(FileBackend, ClearErrors) {
  cfg_.index = 7;
  EXPECT_EQ(open(), -ENOENT);
  EXPECT_EQ(why_, "file: " + dev_ + ": no folder " + dev_ + "/cam7 (is this a `voxcap sim --out` folder?)");
  cfg_.index = 0;
  cfg_.width = 640;
  cfg_.height = 480;
  EXPECT_EQ(open(), -ENOTSUP);
  EXPECT_EQ(why_, "file: " + dev_ + ": size 640x480 not supported (the images are 32x24)");
  cfg_.width = cfg_.height = 0;
  std::string missing = dev_ + "/nope";
  cfg_.device = missing.c_str();
  EXPECT_EQ(open(), -ENOENT);
  EXPECT_EQ(why_, "file: " + missing + ": no such folder");
  fs::create_directories(dir_ / "empty" / "cam0");
  std::string empty = (dir_ / "empty").string();
  cfg_.device = empty.c_str();
  EXPECT_EQ(open(), -ENOENT);
  EXPECT_EQ(why_, "file: " + empty + ": no <number>.png frames in " + empty + "/cam0");
}

TEST_F(FileBackend, FramesAreOrderedByNumberWithoutPadding) {
  fs::path d = dir_ / "unpadded";
  fs::create_directories(d / "cam0");
  for (int n : {10, 2, 1}) write(d / "cam0" / (std::to_string(n) + ".png"), colour(0, n));
  std::string dev = d.string();
  cfg_.device = dev.c_str();
  ASSERT_EQ(open(), 0) << why_;
  for (int pass = 0; pass < 2; pass++) {  // a restart begins again at the first frame
    ASSERT_EQ(vc_camera_start(cam_), 0);
    for (uint64_t want : {1u, 2u, 10u}) {
      vc_frame f;
      ASSERT_EQ(vc_camera_capture(cam_, 100, &f), 0) << vc_camera_last_error(cam_);
      EXPECT_EQ(f.index, want);
      EXPECT_EQ(f.rgb[f.stride], colour(0, (int)want)[0]);
      vc_camera_release(cam_, &f);
    }
    ASSERT_EQ(vc_camera_stop(cam_), 0);
  }
}

TEST_F(FileBackend, UnreadableFrameIsAnIoError) {
  FILE* f = fopen((dir_ / "cam0" / "000002.png").c_str(), "w");
  fputs("not a png", f);
  fclose(f);
  ASSERT_EQ(open(), 0) << why_;
  ASSERT_EQ(vc_camera_start(cam_), 0);
  vc_frame fr;
  for (int n = 0; n < 2; n++) {
    ASSERT_EQ(vc_camera_capture(cam_, 100, &fr), 0);
    vc_camera_release(cam_, &fr);
  }
  EXPECT_EQ(vc_camera_capture(cam_, 100, &fr), -EIO);
  EXPECT_EQ(std::string(vc_camera_last_error(cam_)),
            "file: " + dev_ + ": cannot read image " + (dir_ / "cam0" / "000002.png").string());
}

}  // namespace
