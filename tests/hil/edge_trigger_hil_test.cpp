// Trigger input and frame/pulse pairing on a real board (label hil). Skipped unless named:
//   VOXCAP_HIL_GPIO_CHIP=gpiochip0 VOXCAP_HIL_GPIO_LINE=17   (pulses must arrive: run the host's trigger)
//   plus, for pairing, a triggered camera: VOXCAP_HIL_CAMERA_BACKEND=v4l2|libcamera VOXCAP_HIL_CAMERA=...
//   VOXCAP_HIL_TRIGGER_HZ=60 [VOXCAP_HIL_LATENCY_US=0] [VOXCAP_HIL_EXPOSURE_US=4000]
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "hil_env.hpp"
#include "voxcap/edge/camera.h"
#include "voxcap/edge/clock.h"
#include "voxcap/edge/pairing.h"
#include "voxcap/edge/trigger.h"

namespace {

using vc::hil::env;
using vc::hil::env_long;

vc_trigger* open_gpio(std::string* skip) {
  static std::string chip;
  chip = env("VOXCAP_HIL_GPIO_CHIP");
  if (chip.empty() || env("VOXCAP_HIL_GPIO_LINE").empty()) {
    *skip = "no rig configured: set VOXCAP_HIL_GPIO_CHIP and VOXCAP_HIL_GPIO_LINE to run";
    return nullptr;
  }
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = chip.c_str();
  cfg.line_offset = (unsigned)env_long("VOXCAP_HIL_GPIO_LINE", 0);
  vc_trigger* t = nullptr;
  char why[320];
  EXPECT_EQ(vc_trigger_open(&cfg, &t, why, sizeof why), 0) << why;
  return t;
}

TEST(GpiodHil, CountsPulsesWithKernelTimestamps) {
  std::string skip;
  vc_trigger* t = open_gpio(&skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  ASSERT_NE(t, nullptr);
  vc_pulse prev{}, p{};
  for (int i = 0; i < 120; i++) {
    ASSERT_EQ(vc_trigger_wait(t, 5000, &p), 0) << vc_trigger_last_error(t);
    if (i > 0) {
      EXPECT_EQ(p.seq, prev.seq + 1);
      EXPECT_GT(p.t_ns, prev.t_ns);
    }
    EXPECT_LE(p.t_ns, vc_clock_monotonic_ns());  // stamped on our clock, in the past
    prev = p;
  }
  vc_trigger_stats st;
  vc_trigger_get_stats(t, &st);
  EXPECT_EQ(st.lost, 0u);
  vc_trigger_free(t);
}

TEST(PairingHil, TriggeredCameraFramesPairWithGpioPulses) {
  std::string skip;
  std::string backend = env("VOXCAP_HIL_CAMERA_BACKEND"), device = env("VOXCAP_HIL_CAMERA");
  long hz = env_long("VOXCAP_HIL_TRIGGER_HZ", 0);
  if (backend.empty() || device.empty() || hz <= 0)
    GTEST_SKIP()
        << "no rig configured: set VOXCAP_HIL_CAMERA_BACKEND, VOXCAP_HIL_CAMERA, VOXCAP_HIL_TRIGGER_HZ "
           "and the VOXCAP_HIL_GPIO_* pair to run";
  vc_trigger* t = open_gpio(&skip);
  if (!skip.empty()) GTEST_SKIP() << skip;
  ASSERT_NE(t, nullptr);

  vc_camera_config cc;
  vc_camera_config_init(&cc);
  cc.backend = backend.c_str();
  cc.device = device.c_str();
  cc.external_trigger = true;
  cc.exposure_us = env_long("VOXCAP_HIL_EXPOSURE_US", 4000);
  cc.fps_num = (uint32_t)hz;
  vc_camera* cam = nullptr;
  char why[320];
  ASSERT_EQ(vc_camera_open(&cc, &cam, why, sizeof why), 0) << why;

  vc_pairing_config pc;
  vc_pairing_config_init(&pc);
  pc.ncams = 1;
  pc.tolerance_ns = 1000000000ull / (uint64_t)hz / 2 - 500000;
  pc.latency_ns[0] = env_long("VOXCAP_HIL_LATENCY_US", 0) * 1000;
  std::vector<vc_pair_event> events;
  auto cb = [](void* user, const vc_pair_event* ev) {
    static_cast<std::vector<vc_pair_event>*>(user)->push_back(*ev);
  };
  vc_pairer* pr = nullptr;
  ASSERT_EQ(vc_pairer_new(&pc, cb, &events, &pr, nullptr, 0), 0);

  std::mutex mu;
  std::atomic<bool> stop{false};
  std::thread pulses([&] {
    while (!stop) {
      vc_pulse p;
      if (vc_trigger_wait(t, 100, &p) == 0) {
        std::lock_guard<std::mutex> lock(mu);
        vc_pairer_add_pulse(pr, p.seq, p.t_ns);
      }
    }
  });
  ASSERT_EQ(vc_camera_start(cam), 0) << vc_camera_last_error(cam);
  for (int i = 0; i < 5 * hz; i++) {
    vc_frame f;
    ASSERT_EQ(vc_camera_capture(cam, 2000, &f), 0) << vc_camera_last_error(cam);
    std::lock_guard<std::mutex> lock(mu);
    vc_pairer_add_frame(pr, 0, f.t_ns, f.sequence);
    vc_pairer_advance(pr, vc_clock_monotonic_ns());
    vc_camera_release(cam, &f);
  }
  stop = true;
  pulses.join();
  vc_pairer_flush(pr);
  vc_pairing_stats st;
  vc_pairer_get_stats(pr, &st);
  std::printf(
      "hil: matched %llu, frames without pulse %llu, pulses without frame %llu, error %lld..%lld ns\n",
      (unsigned long long)st.matched[0], (unsigned long long)st.frames_without_pulse[0],
      (unsigned long long)st.pulses_without_frame[0], (long long)st.error_min_ns[0],
      (long long)st.error_max_ns[0]);
  // a triggered camera exposes exactly once per pulse: every frame has its pulse
  EXPECT_GE(st.matched[0], (uint64_t)(5 * hz - 2));
  EXPECT_LE(st.frames_without_pulse[0], 2u);  // at most the edges of the run
  vc_pairer_free(pr);
  vc_camera_free(cam);
  vc_trigger_free(t);
}

}  // namespace
