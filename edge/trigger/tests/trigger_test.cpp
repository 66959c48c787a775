// vc_trigger: the factory, configuration errors, the gpiod backend's error path, the seq window.
#include <gtest/gtest.h>

#include <cerrno>
#include <string>

#include "trigger_backend.h"
#include "voxcap/edge/trigger.h"

namespace {

std::string open_error(const vc_trigger_config& cfg, int* rc) {
  char why[512];
  vc_trigger* t = nullptr;
  *rc = vc_trigger_open(&cfg, &t, why, sizeof why);
  EXPECT_EQ(t, nullptr);
  vc_trigger_free(t);
  return why;
}

}  // namespace

TEST(Trigger, BackendNames) {
  const char* const* names = vc_trigger_backend_names();
  ASSERT_NE(names, nullptr);
  EXPECT_STREQ(names[0], "gpiod");
  EXPECT_STREQ(names[1], "udp");
  EXPECT_EQ(names[2], nullptr);
}

TEST(Trigger, UnknownOrMissingBackendIsRejected) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  int rc = 0;
  EXPECT_EQ(open_error(cfg, &rc), "trigger config: no backend given (one of gpiod, udp)");
  EXPECT_EQ(rc, -EINVAL);
  cfg.backend = "ftdi";
  EXPECT_EQ(open_error(cfg, &rc), "trigger config: unknown backend 'ftdi' (one of gpiod, udp)");
  EXPECT_EQ(rc, -EINVAL);
}

TEST(Trigger, BoottimeEventClockIsRejected) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = "gpiochip0";
  cfg.event_clock = VC_CLOCK_BOOTTIME;
  int rc = 0;
  EXPECT_NE(open_error(cfg, &rc).find("event_clock"), std::string::npos);
  EXPECT_EQ(rc, -EINVAL);
}

TEST(TriggerGpiod, MissingChipGivesAClearError) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = "/dev/gpiochip-does-not-exist";
  cfg.line_offset = 17;
  int rc = 0;
  EXPECT_EQ(open_error(cfg, &rc),
            "gpiod: /dev/gpiochip-does-not-exist: cannot open chip: No such file or directory");
  EXPECT_EQ(rc, -ENOENT);
}

TEST(TriggerGpiod, ChipNameIsLookedUpInDev) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = "gpiochip987";
  int rc = 0;
  EXPECT_EQ(open_error(cfg, &rc), "gpiod: /dev/gpiochip987: cannot open chip: No such file or directory");
  EXPECT_EQ(rc, -ENOENT);
}

TEST(TriggerGpiod, NonGpioDeviceIsRejected) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  cfg.chip = "/dev/null";
  int rc = 0;
  std::string why = open_error(cfg, &rc);
  EXPECT_EQ(why.rfind("gpiod: /dev/null: cannot open chip: ", 0), 0u) << why;
  EXPECT_LT(rc, 0);
}

TEST(TriggerGpiod, NoChipConfigured) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "gpiod";
  int rc = 0;
  EXPECT_EQ(open_error(cfg, &rc), "gpiod: no chip given (e.g. gpiochip0)");
  EXPECT_EQ(rc, -EINVAL);
}

TEST(SeqWindow, CountsGapsLateAndDuplicates) {
  vc_seq_window w = {};
  int64_t d = 0;
  EXPECT_EQ(vc_seq_window_push(&w, 10, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);  // the first pulse seen sets the start: nothing before it counts as lost
  EXPECT_EQ(vc_seq_window_push(&w, 11, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(vc_seq_window_push(&w, 15, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 3);  // 12, 13, 14
  EXPECT_EQ(vc_seq_window_push(&w, 13, &d), VC_SEQ_LATE);
  EXPECT_EQ(d, -1);
  EXPECT_EQ(vc_seq_window_push(&w, 13, &d), VC_SEQ_DUPLICATE);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(vc_seq_window_push(&w, 15, &d), VC_SEQ_DUPLICATE);
  EXPECT_EQ(vc_seq_window_push(&w, 11, &d), VC_SEQ_DUPLICATE);
  EXPECT_EQ(vc_seq_window_push(&w, 16, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);
}

TEST(SeqWindow, FarJumpBackIsARestart) {
  vc_seq_window w = {};
  int64_t d = 0;
  vc_seq_window_push(&w, 1000, &d);
  EXPECT_EQ(vc_seq_window_push(&w, 0, &d), VC_SEQ_RESTART);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(vc_seq_window_push(&w, 1, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);
}

// Issue #13: one forged datagram with seq 100000 moved every edge's count there. A jump ahead beyond
// VC_SEQ_MAX_JUMP is dropped; the host's next pulses go on as if it never came. Only a datagram that
// follows the dropped one in sequence makes it a real move of the host's count.
TEST(SeqWindow, ImplausibleJumpIsDroppedUnlessTheNextConfirmsIt) {
  vc_seq_window w = {};
  int64_t d = 0;
  EXPECT_EQ(vc_seq_window_push(&w, 500, &d), VC_SEQ_NEXT);
  EXPECT_EQ(vc_seq_window_push(&w, 100000, &d), VC_SEQ_JUMP);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(vc_seq_window_push(&w, 501, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);                                             // nothing counted lost for the forged one
  EXPECT_EQ(vc_seq_window_push(&w, 100001, &d), VC_SEQ_JUMP);  // 501 came between: not confirmed
  EXPECT_EQ(vc_seq_window_push(&w, 502, &d), VC_SEQ_NEXT);
  EXPECT_EQ(vc_seq_window_push(&w, 502 + VC_SEQ_MAX_JUMP, &d), VC_SEQ_NEXT);  // at the bound: plausible
  EXPECT_EQ(d, int64_t{VC_SEQ_MAX_JUMP} - 1);
  // A host that really jumped: its next pulse follows the dropped one, and the window moves there.
  const uint64_t far = 1u << 20;
  EXPECT_EQ(vc_seq_window_push(&w, far, &d), VC_SEQ_JUMP);
  EXPECT_EQ(vc_seq_window_push(&w, far + 1, &d), VC_SEQ_RESTART);
  EXPECT_EQ(vc_seq_window_push(&w, far + 2, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(vc_seq_window_push(&w, far, &d), VC_SEQ_LATE);  // the dropped one again: inside the window
}

TEST(SeqWindow, BigGapForgetsTheWindow) {
  vc_seq_window w = {};
  int64_t d = 0;
  vc_seq_window_push(&w, 0, &d);
  EXPECT_EQ(vc_seq_window_push(&w, 200, &d), VC_SEQ_NEXT);
  EXPECT_EQ(d, 199);
  EXPECT_EQ(vc_seq_window_push(&w, 199, &d), VC_SEQ_LATE);
  EXPECT_EQ(d, -1);
  EXPECT_EQ(vc_seq_window_push(&w, 137, &d), VC_SEQ_LATE);     // 63 back: still inside the window
  EXPECT_EQ(vc_seq_window_push(&w, 100, &d), VC_SEQ_RESTART);  // 100 back: outside
}
