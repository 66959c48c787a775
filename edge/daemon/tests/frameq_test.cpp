// The daemon's frame pairs and queues, without threads: slots through their states, complete pairs,
// drops when the pipeline is behind, phase resets.
#include "frameq.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <string>

namespace {

constexpr uint64_t kMs = 1000000;

struct FrameQueue : ::testing::Test {
  vc_frameq* q = nullptr;
  ~FrameQueue() override { vc_frameq_free(q); }

  void make(unsigned nslots) {
    vc_pairing_config pc;
    vc_pairing_config_init(&pc);
    pc.ncams = 2;
    pc.pulse_slots = 16;
    pc.frame_slots = nslots;
    char why[128] = "";
    ASSERT_EQ(vc_frameq_new(&pc, nslots, &q, why, sizeof(why)), 0) << why;
  }
  // Both cameras' frames of pulse seq at time t (1 µs after the edge); returns the slots used.
  void frames(uint64_t t, uint64_t now, int slots[2]) {
    for (unsigned c = 0; c < 2; c++) {
      slots[c] = vc_frameq_acquire(q, c);
      ASSERT_GE(slots[c], 0);
      vc_frameq_add_frame(q, c, slots[c], t + 1000, now);
    }
  }
};

TEST_F(FrameQueue, RejectsWhatItCannotHold) {
  vc_pairing_config pc;
  vc_pairing_config_init(&pc);
  pc.ncams = 2;
  pc.frame_slots = 8;
  char why[128] = "";
  EXPECT_EQ(vc_frameq_new(&pc, 0, &q, why, sizeof(why)), -EINVAL);
  EXPECT_EQ(vc_frameq_new(&pc, 9, &q, why, sizeof(why)), -EINVAL);
  EXPECT_EQ(std::string(why), "frame queue: frame slots must be 1..8");
  pc.ncams = 3;
  EXPECT_EQ(vc_frameq_new(&pc, 4, &q, why, sizeof(why)), -EINVAL);
  pc.ncams = 2;
  pc.frame_slots = 2;
  EXPECT_EQ(vc_frameq_new(&pc, 4, &q, why, sizeof(why)), -EINVAL);
  EXPECT_EQ(q, nullptr);
  vc_frameq_free(nullptr);
}

TEST_F(FrameQueue, ClosedTakesNothing) {
  make(2);
  EXPECT_FALSE(vc_frameq_is_open(q));
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EAGAIN);
  EXPECT_FALSE(vc_frameq_add_pulse(q, 1, 1000 * kMs, 1000 * kMs));
  vc_frameq_stats st;
  vc_frameq_get_stats(q, &st);
  EXPECT_EQ(st.pairing.pulses, 0u);
  EXPECT_EQ(st.slot_drops[0], 0u);
}

TEST_F(FrameQueue, PulseAndBothFramesMakeAPairWhoseSlotsStayTakenUntilDone) {
  make(1);
  vc_frameq_reset(q, true, 0, false);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 7, 1000 * kMs, 1000 * kMs));
  int slots[2];
  frames(1000 * kMs, 1002 * kMs, slots);
  ASSERT_EQ(vc_frameq_ready(q), 1u);
  vc_frame_pair p;
  ASSERT_TRUE(vc_frameq_pop(q, &p));
  EXPECT_EQ(p.seq, 7u);
  EXPECT_EQ(p.t_ns, 1000 * kMs);
  EXPECT_EQ(p.paired_ns, 1002 * kMs);
  EXPECT_EQ(p.slot[0], slots[0]);
  EXPECT_EQ(p.slot[1], slots[1]);
  EXPECT_FALSE(vc_frameq_pop(q, &p));
  // the pipeline holds the only slot: the next frame is dropped and counted
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EBUSY);
  vc_frameq_stats st;
  vc_frameq_get_stats(q, &st);
  EXPECT_EQ(st.slot_drops[0], 1u);
  EXPECT_EQ(st.pairing.complete, 1u);
  vc_frameq_done(q, &p);
  EXPECT_EQ(vc_frameq_acquire(q, 0), 0);
}

TEST_F(FrameQueue, FramesBeforeTheirPulsePairToo) {
  make(2);
  vc_frameq_reset(q, true, 0, false);
  int slots[2];
  frames(2000 * kMs, 2000 * kMs, slots);
  EXPECT_EQ(vc_frameq_ready(q), 0u);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 3, 2000 * kMs, 2001 * kMs));
  vc_frame_pair p;
  ASSERT_TRUE(vc_frameq_pop(q, &p));
  EXPECT_EQ(p.seq, 3u);
  EXPECT_EQ(p.paired_ns, 2001 * kMs);
}

TEST_F(FrameQueue, PipelineBehindDropsFramesAndCountsThem) {
  make(8);
  vc_frameq_reset(q, true, 0, false);
  for (uint64_t n = 0; n < 8; n++) {
    uint64_t t = (1000 + 16 * n) * kMs;
    ASSERT_TRUE(vc_frameq_add_pulse(q, n, t, t));
    int slots[2];
    frames(t, t + kMs, slots);
  }
  EXPECT_EQ(vc_frameq_ready(q), 8u);
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EBUSY);
  EXPECT_EQ(vc_frameq_acquire(q, 1), -EBUSY);
  vc_frameq_stats st;
  vc_frameq_get_stats(q, &st);
  EXPECT_EQ(st.slot_drops[0] + st.slot_drops[1], 2u);
  for (uint64_t n = 0; n < 8; n++) {  // oldest first
    vc_frame_pair p;
    ASSERT_TRUE(vc_frameq_pop(q, &p));
    EXPECT_EQ(p.seq, n);
    vc_frameq_done(q, &p);
  }
  EXPECT_GE(vc_frameq_acquire(q, 0), 0);
}

TEST_F(FrameQueue, UnmatchedFramesAndPulsesGiveTheirSlotsBack) {
  make(1);
  vc_frameq_reset(q, true, 0, false);
  // a frame no pulse comes for
  int s = vc_frameq_acquire(q, 0);
  ASSERT_EQ(s, 0);
  vc_frameq_add_frame(q, 0, s, 1000 * kMs, 1000 * kMs);
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EBUSY);
  vc_frameq_advance(q, 1200 * kMs);
  EXPECT_EQ(vc_frameq_acquire(q, 0), 0);
  vc_frameq_add_frame(q, 0, 0, 1300 * kMs, 1300 * kMs);
  // ... which matches the pulse, but camera 1 never delivers
  ASSERT_TRUE(vc_frameq_add_pulse(q, 9, 1300 * kMs, 1300 * kMs));
  vc_frameq_advance(q, 1500 * kMs);
  EXPECT_EQ(vc_frameq_ready(q), 0u);
  vc_frameq_stats st;
  vc_frameq_get_stats(q, &st);
  EXPECT_EQ(st.pairing.frames_without_pulse[0], 1u);
  EXPECT_EQ(st.pairing.pulses_without_frame[1], 1u);
  EXPECT_EQ(vc_frameq_acquire(q, 0), 0);
}

TEST_F(FrameQueue, ResetForgetsThePhaseAndDoneDoesNotFreeASlotTakenSince) {
  make(1);
  vc_frameq_reset(q, true, 0, false);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 1, 1000 * kMs, 1000 * kMs));
  int slots[2];
  frames(1000 * kMs, 1000 * kMs, slots);
  vc_frame_pair p;
  ASSERT_TRUE(vc_frameq_pop(q, &p));
  vc_frameq_reset(q, true, 100, false);   // e.g. START while the pipeline still works on p
  ASSERT_EQ(vc_frameq_acquire(q, 0), 0);  // the new phase's frame
  vc_frameq_done(q, &p);
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EBUSY) << "done() freed a slot of the new phase";
  // pulses below the phase's first seq are ignored
  EXPECT_FALSE(vc_frameq_add_pulse(q, 99, 2000 * kMs, 2000 * kMs));
  EXPECT_TRUE(vc_frameq_add_pulse(q, 100, 2016 * kMs, 2016 * kMs));
  vc_frameq_reset(q, false, 0, false);
  EXPECT_FALSE(vc_frameq_is_open(q));
  EXPECT_EQ(vc_frameq_acquire(q, 0), -EAGAIN);
}

TEST_F(FrameQueue, CaptureStageIsTimedOnlyWhenAsked) {
  make(2);
  vc_frameq_reset(q, true, 0, false);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 1, 1000 * kMs, 1000 * kMs));
  int slots[2];
  frames(1000 * kMs, 1003 * kMs, slots);
  uint64_t sum, max, n;
  vc_frameq_take_capture_time(q, &sum, &max, &n);
  EXPECT_EQ(n, 0u);
  vc_frameq_reset(q, true, 0, true);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 2, 2000 * kMs, 2000 * kMs));
  frames(2000 * kMs, 2003 * kMs, slots);
  ASSERT_TRUE(vc_frameq_add_pulse(q, 3, 2016 * kMs, 2016 * kMs));
  vc_frame_pair p;
  ASSERT_TRUE(vc_frameq_pop(q, &p));
  vc_frameq_done(q, &p);
  frames(2016 * kMs, 2021 * kMs, slots);
  vc_frameq_take_capture_time(q, &sum, &max, &n);
  EXPECT_EQ(n, 2u);
  EXPECT_EQ(sum, 8 * kMs);
  EXPECT_EQ(max, 5 * kMs);
  vc_frameq_take_capture_time(q, &sum, &max, &n);
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(sum, 0u);
}

}  // namespace
