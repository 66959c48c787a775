// vc_capture_new: the edge's constructor shape (0 or -errno, *out NULL on failure, a reason in why
// that names the part that failed). The threads are exercised end to end by the emulated rig.
#include "capture.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <string>

namespace {

struct Options {
  vc_capture_options opt{};
  vc_trigger_config trig{};
  Options() {
    vc_trigger_config_init(&trig);
    trig.backend = "udp";
    trig.bind_address = "127.0.0.1";
    trig.port = 0;
    for (auto& c : opt.cameras) {
      vc_camera_config_init(&c);
      c.backend = "file";
      c.device = "/nonexistent/voxcap-capture-test";
    }
    opt.trigger = &trig;
    vc_pairing_config_init(&opt.pairing);
  }
};

}  // namespace

TEST(Capture, NewRefusesMissingArguments) {
  vc_capture* cap = reinterpret_cast<vc_capture*>(0x1);
  char why[256] = "stale";
  EXPECT_EQ(vc_capture_new(nullptr, nullptr, &cap, why, sizeof why), -EINVAL);
  EXPECT_EQ(cap, nullptr);
  EXPECT_STREQ(why, "capture: invalid arguments");
}

TEST(Capture, NewSaysWhichTriggerFailed) {
  Options o;
  o.trig.backend = "smoke-signals";
  vc_capture* cap = reinterpret_cast<vc_capture*>(0x1);
  char why[256] = "";
  EXPECT_EQ(vc_capture_new(&o.opt, nullptr, &cap, why, sizeof why), -EINVAL);
  EXPECT_EQ(cap, nullptr);
  EXPECT_EQ(std::string(why).rfind("trigger: trigger config: unknown backend 'smoke-signals'", 0), 0u) << why;
}

TEST(Capture, NewSaysWhichCameraFailedAndLeavesNothing) {
  Options o;
  vc_capture* cap = reinterpret_cast<vc_capture*>(0x1);
  char why[256] = "";
  EXPECT_LT(vc_capture_new(&o.opt, nullptr, &cap, why, sizeof why), 0);
  EXPECT_EQ(cap, nullptr);
  EXPECT_EQ(std::string(why).rfind("camera 0 (file /nonexistent/voxcap-capture-test): ", 0), 0u) << why;
  vc_capture_free(nullptr);
}
