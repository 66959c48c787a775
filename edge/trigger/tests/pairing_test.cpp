// vc_pairer: frame/pulse pairing by timestamp, with synthetic sequences (jitter, drops on either
// side, out-of-order arrival) whose truth is known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "voxcap/edge/pairing.h"

namespace {

constexpr uint64_t kMs = 1000000;

struct Recorder {
  std::vector<vc_pair_event> events;
  static void cb(void* user, const vc_pair_event* ev) { static_cast<Recorder*>(user)->events.push_back(*ev); }
  std::vector<vc_pair_event> of(vc_pair_event_type t) const {
    std::vector<vc_pair_event> out;
    for (const auto& e : events)
      if (e.type == t) out.push_back(e);
    return out;
  }
};

struct Pairer {
  explicit Pairer(const vc_pairing_config& cfg) {
    EXPECT_EQ(vc_pairer_new(&cfg, &Recorder::cb, &rec, &p, nullptr, 0), 0);
  }
  ~Pairer() { vc_pairer_free(p); }
  vc_pairing_stats stats() const {
    vc_pairing_stats s;
    vc_pairer_get_stats(p, &s);
    return s;
  }
  Recorder rec;
  vc_pairer* p = nullptr;
};

vc_pairing_config two_cams() {
  vc_pairing_config cfg;
  vc_pairing_config_init(&cfg);
  cfg.ncams = 2;
  cfg.tolerance_ns = 4 * kMs;
  cfg.max_delay_ns = 20 * kMs;
  return cfg;
}

}  // namespace

TEST(PairingConfig, Validates) {
  vc_pairing_config cfg;
  vc_pairing_config_init(&cfg);
  char why[128];
  EXPECT_EQ(vc_pairing_config_check(&cfg, why, sizeof why), 0);
  cfg.ncams = 0;
  EXPECT_EQ(vc_pairing_config_check(&cfg, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "pairing config: ncams must be 1..4");
  cfg.ncams = 2;
  cfg.tolerance_ns = 0;
  EXPECT_EQ(vc_pairing_config_check(&cfg, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "pairing config: tolerance must be > 0");
  cfg.tolerance_ns = kMs;
  cfg.pulse_slots = 1000;
  EXPECT_EQ(vc_pairing_config_check(&cfg, why, sizeof why), -EINVAL);
  vc_pairer* p = nullptr;
  EXPECT_EQ(vc_pairer_new(&cfg, &Recorder::cb, nullptr, &p, why, sizeof why), -EINVAL);
  EXPECT_EQ(p, nullptr);
  EXPECT_STREQ(why, "pairing config: pulse_slots / frame_slots must be at most 256");
  vc_pairing_config_init(&cfg);
  EXPECT_EQ(vc_pairer_new(&cfg, nullptr, nullptr, &p, why, sizeof why), -EINVAL);
  EXPECT_EQ(p, nullptr);
  EXPECT_STREQ(why, "pairer: no pair callback");
  // a good config clears a stale reason; free(NULL) is a no-op
  ASSERT_EQ(vc_pairer_new(&cfg, &Recorder::cb, nullptr, &p, why, sizeof why), 0);
  EXPECT_STREQ(why, "");
  vc_pairer_free(p);
  vc_pairer_free(nullptr);
}

TEST(Pairing, PulseThenFramesCompletes) {
  auto cfg = two_cams();
  cfg.latency_ns[0] = 2 * kMs;
  cfg.latency_ns[1] = -1 * kMs;
  Pairer pr(cfg);
  ASSERT_EQ(vc_pairer_add_pulse(pr.p, 7, 100 * kMs), 0);
  ASSERT_EQ(vc_pairer_add_frame(pr.p, 0, 102 * kMs + 300, 70), 0);
  EXPECT_TRUE(pr.rec.of(VC_PAIR_COMPLETE).empty());
  ASSERT_EQ(vc_pairer_add_frame(pr.p, 1, 99 * kMs - 200, 71), 0);
  auto m = pr.rec.of(VC_PAIR_MATCHED);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].cam, 0u);
  EXPECT_EQ(m[0].seq, 7u);
  EXPECT_EQ(m[0].cookie, 70u);
  EXPECT_EQ(m[0].error_ns, 300);
  EXPECT_EQ(m[1].cam, 1u);
  EXPECT_EQ(m[1].cookie, 71u);
  EXPECT_EQ(m[1].error_ns, -200);
  auto c = pr.rec.of(VC_PAIR_COMPLETE);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].seq, 7u);
  EXPECT_EQ(pr.rec.events.back().type, VC_PAIR_COMPLETE);
  EXPECT_EQ(vc_pairer_pending_pulses(pr.p), 0u);
  auto s = pr.stats();
  EXPECT_EQ(s.complete, 1u);
  EXPECT_EQ(s.error_min_ns[0], 300);
  EXPECT_EQ(s.error_max_ns[1], -200);
}

TEST(Pairing, FrameBeforeItsPulseWaits) {
  Pairer pr(two_cams());
  vc_pairer_add_frame(pr.p, 0, 100 * kMs + 1000, 1);
  vc_pairer_add_frame(pr.p, 1, 100 * kMs - 1000, 2);
  EXPECT_EQ(vc_pairer_pending_frames(pr.p, 0), 1u);
  EXPECT_TRUE(pr.rec.events.empty());
  vc_pairer_advance(pr.p, 110 * kMs);  // within max_delay: still waiting
  EXPECT_TRUE(pr.rec.events.empty());
  vc_pairer_add_pulse(pr.p, 3, 100 * kMs);
  ASSERT_EQ(pr.rec.of(VC_PAIR_MATCHED).size(), 2u);
  ASSERT_EQ(pr.rec.of(VC_PAIR_COMPLETE).size(), 1u);
  EXPECT_EQ(vc_pairer_pending_frames(pr.p, 0), 0u);
}

TEST(Pairing, FrameOutsideToleranceIsUnmatchedAfterTheDelay) {
  Pairer pr(two_cams());
  vc_pairer_add_pulse(pr.p, 1, 100 * kMs);
  vc_pairer_add_frame(pr.p, 0, 105 * kMs, 9);  // 5 ms off, tolerance 4 ms
  EXPECT_TRUE(pr.rec.of(VC_PAIR_MATCHED).empty());
  vc_pairer_advance(pr.p, 105 * kMs + 4 * kMs + 20 * kMs);  // exactly at the deadline: not yet
  EXPECT_TRUE(pr.rec.of(VC_PAIR_FRAME_UNMATCHED).empty());
  vc_pairer_advance(pr.p, 130 * kMs);
  auto u = pr.rec.of(VC_PAIR_FRAME_UNMATCHED);
  ASSERT_EQ(u.size(), 1u);
  EXPECT_EQ(u[0].cam, 0u);
  EXPECT_EQ(u[0].cookie, 9u);
  // the pulse, whose cam-0 window (100 ± 4 ms) is past, resolves without cam 0 — and without cam 1
  auto pu = pr.rec.of(VC_PAIR_PULSE_UNMATCHED);
  ASSERT_EQ(pu.size(), 1u);
  EXPECT_EQ(pu[0].seq, 1u);
  EXPECT_EQ(pu[0].missing_mask, 3u);
  auto s = pr.stats();
  EXPECT_EQ(s.frames_without_pulse[0], 1u);
  EXPECT_EQ(s.pulses_without_frame[0], 1u);
  EXPECT_EQ(s.pulses_without_frame[1], 1u);
}

TEST(Pairing, ALaterFrameProvesAPulseWasSkipped) {
  Pairer pr(two_cams());
  vc_pairer_add_pulse(pr.p, 1, 100 * kMs);
  vc_pairer_add_pulse(pr.p, 2, 116 * kMs);
  vc_pairer_add_frame(pr.p, 0, 100 * kMs, 10);
  vc_pairer_add_frame(pr.p, 1, 100 * kMs, 11);
  // camera 1 drops the frame of pulse 2 and delivers the next one; camera 0 delivers pulse 2's
  vc_pairer_add_frame(pr.p, 0, 116 * kMs, 20);
  vc_pairer_add_pulse(pr.p, 3, 132 * kMs);
  vc_pairer_add_frame(pr.p, 1, 132 * kMs, 31);  // no `now` needed: the frame order tells
  auto pu = pr.rec.of(VC_PAIR_PULSE_UNMATCHED);
  ASSERT_EQ(pu.size(), 1u);
  EXPECT_EQ(pu[0].seq, 2u);
  EXPECT_EQ(pu[0].missing_mask, 2u);
  EXPECT_EQ(pr.stats().pulses_without_frame[1], 1u);
  EXPECT_EQ(pr.stats().pulses_without_frame[0], 0u);
}

TEST(Pairing, ALatePulseForAFramePastIsMarkedSkipped) {
  Pairer pr(two_cams());
  vc_pairer_add_frame(pr.p, 0, 200 * kMs, 1);
  vc_pairer_add_frame(pr.p, 1, 200 * kMs, 2);
  vc_pairer_add_pulse(pr.p, 20, 200 * kMs);  // completes
  vc_pairer_add_pulse(pr.p, 19, 184 * kMs);  // arrives late, both cameras already past it
  auto pu = pr.rec.of(VC_PAIR_PULSE_UNMATCHED);
  ASSERT_EQ(pu.size(), 1u);
  EXPECT_EQ(pu[0].seq, 19u);
  EXPECT_EQ(pu[0].missing_mask, 3u);
}

TEST(Pairing, CameraThatStopsLeavesPulsesUnmatchedOnAdvance) {
  auto cfg = two_cams();
  cfg.latency_ns[1] = 3 * kMs;
  Pairer pr(cfg);
  vc_pairer_add_pulse(pr.p, 1, 100 * kMs);
  vc_pairer_add_frame(pr.p, 0, 100 * kMs, 0);
  vc_pairer_advance(pr.p, 100 * kMs + 3 * kMs + 4 * kMs + 20 * kMs);  // at cam 1's deadline: wait
  EXPECT_TRUE(pr.rec.of(VC_PAIR_PULSE_UNMATCHED).empty());
  vc_pairer_advance(pr.p, 128 * kMs);
  auto pu = pr.rec.of(VC_PAIR_PULSE_UNMATCHED);
  ASSERT_EQ(pu.size(), 1u);
  EXPECT_EQ(pu[0].missing_mask, 2u);
}

TEST(Pairing, DuplicatePulseIsIgnored) {
  Pairer pr(two_cams());
  EXPECT_EQ(vc_pairer_add_pulse(pr.p, 5, 100 * kMs), 0);
  EXPECT_EQ(vc_pairer_add_pulse(pr.p, 5, 100 * kMs), -EEXIST);
  EXPECT_EQ(pr.stats().duplicate_pulses, 1u);
  EXPECT_EQ(pr.stats().pulses, 1u);
  EXPECT_EQ(vc_pairer_add_frame(pr.p, 2, 0, 0), -EINVAL);  // no camera 2
}

TEST(Pairing, NearestPulseWinsWhenTwoAreInTolerance) {
  auto cfg = two_cams();
  cfg.ncams = 1;
  cfg.tolerance_ns = 10 * kMs;  // wider than half the spacing below, on purpose
  Pairer pr(cfg);
  vc_pairer_add_pulse(pr.p, 1, 100 * kMs);
  vc_pairer_add_pulse(pr.p, 2, 108 * kMs);
  vc_pairer_add_frame(pr.p, 0, 107 * kMs, 0);
  auto m = pr.rec.of(VC_PAIR_MATCHED);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].seq, 2u);
}

TEST(Pairing, RingOverflowResolvesTheOldestEarly) {
  auto cfg = two_cams();
  cfg.pulse_slots = 4;
  cfg.frame_slots = 2;
  Pairer pr(cfg);
  for (uint64_t s = 0; s < 6; s++) vc_pairer_add_pulse(pr.p, s, (100 + 16 * s) * kMs);  // no frames at all
  EXPECT_EQ(vc_pairer_pending_pulses(pr.p), 4u);
  auto pu = pr.rec.of(VC_PAIR_PULSE_UNMATCHED);
  ASSERT_EQ(pu.size(), 2u);
  EXPECT_EQ(pu[0].seq, 0u);
  EXPECT_EQ(pu[1].seq, 1u);
  for (uint64_t i = 0; i < 3; i++) vc_pairer_add_frame(pr.p, 1, (1000 + 16 * i) * kMs, i);  // no pulses
  EXPECT_EQ(vc_pairer_pending_frames(pr.p, 1), 2u);
  EXPECT_EQ(pr.stats().overflow, 3u);
  vc_pairer_flush(pr.p);
  EXPECT_EQ(vc_pairer_pending_pulses(pr.p), 0u);
  EXPECT_EQ(vc_pairer_pending_frames(pr.p, 1), 0u);
  EXPECT_EQ(pr.stats().frames_without_pulse[1], 3u);
}

// A long synthetic run: 2 cameras at 60 Hz with per-camera latency and jitter, random drops of
// pulses (lost datagrams) and of frames (camera hiccups), and random delivery delays so that pulses
// and frames interleave out of order. The truth (which pulse each frame belongs to) is in the cookie.
struct Scenario {
  uint64_t seed;
  double drop_pulse, drop_frame;
  uint64_t pulse_delay_max, frame_delay_max;
};

class PairingRun : public ::testing::TestWithParam<Scenario> {};

TEST_P(PairingRun, EveryFrameFindsItsPulseAndEveryDropIsCounted) {
  const Scenario sc = GetParam();
  const uint64_t period = 16666667;  // 60 Hz
  const int n = 600;
  auto cfg = two_cams();
  cfg.tolerance_ns = period / 2 - kMs;  // 7.3 ms
  cfg.latency_ns[0] = 5 * kMs;          // e.g. exposure + readout
  cfg.latency_ns[1] = 2 * kMs;
  cfg.max_delay_ns = std::max(sc.pulse_delay_max, sc.frame_delay_max) + kMs;
  cfg.pulse_slots = 16;
  cfg.frame_slots = 8;
  Pairer pr(cfg);

  std::mt19937_64 rng(sc.seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::uniform_int_distribution<int64_t> jitter(-500000, 500000);  // ±0.5 ms
  struct Arrival {
    uint64_t at;
    int kind;  // 0 pulse, 1 frame
    unsigned cam;
    uint64_t seq, t;
  };
  std::vector<Arrival> arrivals;
  std::set<uint64_t> dropped_pulses;
  std::map<unsigned, std::set<uint64_t>> dropped_frames;
  const uint64_t t0 = 5000000000ull;
  for (int i = 0; i < n; i++) {
    uint64_t seq = 1000 + (uint64_t)i, tp = t0 + (uint64_t)i * period;
    if (u01(rng) < sc.drop_pulse)
      dropped_pulses.insert(seq);
    else
      arrivals.push_back({tp + (uint64_t)(u01(rng) * (double)sc.pulse_delay_max), 0, 0, seq, tp});
    for (unsigned c = 0; c < 2; c++) {
      if (u01(rng) < sc.drop_frame) {
        dropped_frames[c].insert(seq);
        continue;
      }
      uint64_t tf = (uint64_t)((int64_t)tp + cfg.latency_ns[c] + jitter(rng));
      arrivals.push_back({tf + (uint64_t)(u01(rng) * (double)sc.frame_delay_max), 1, c, seq, tf});
    }
  }
  // one camera's frames are delivered in order: make its arrival times monotonic
  for (unsigned c = 0; c < 2; c++) {
    uint64_t last = 0;
    for (auto& a : arrivals)
      if (a.kind == 1 && a.cam == c) last = a.at = std::max(a.at, last);
  }
  if (sc.drop_pulse > 0) ASSERT_FALSE(dropped_pulses.empty());
  if (sc.drop_frame > 0) ASSERT_FALSE(dropped_frames[0].empty() && dropped_frames[1].empty());
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const Arrival& a, const Arrival& b) { return a.at < b.at; });
  for (const auto& a : arrivals) {
    vc_pairer_advance(pr.p, a.at);
    if (a.kind == 0)
      ASSERT_EQ(vc_pairer_add_pulse(pr.p, a.seq, a.t), 0);
    else
      ASSERT_EQ(vc_pairer_add_frame(pr.p, a.cam, a.t, a.seq), 0);  // cookie = true seq
    ASSERT_LE(vc_pairer_pending_pulses(pr.p), 16u);
  }
  vc_pairer_advance(pr.p, arrivals.back().at + 10 * period);
  EXPECT_EQ(vc_pairer_pending_pulses(pr.p), 0u);

  // no frame is ever paired with the wrong pulse
  uint64_t matched = 0;
  for (const auto& e : pr.rec.of(VC_PAIR_MATCHED)) {
    ASSERT_EQ(e.seq, e.cookie) << "cam " << e.cam;
    matched++;
  }
  // frames of dropped pulses are exactly the unmatched frames
  std::map<unsigned, uint64_t> expect_unmatched_frames, expect_missing;
  for (unsigned c = 0; c < 2; c++)
    for (uint64_t s : dropped_pulses)
      if (!dropped_frames[c].count(s)) expect_unmatched_frames[c]++;
  for (const auto& e : pr.rec.of(VC_PAIR_FRAME_UNMATCHED)) {
    ASSERT_TRUE(dropped_pulses.count(e.cookie)) << e.cookie;
  }
  // pulses whose frame a camera dropped are exactly the pulses reported missing that camera
  for (unsigned c = 0; c < 2; c++)
    for (uint64_t s : dropped_frames[c])
      if (!dropped_pulses.count(s)) expect_missing[c]++;
  for (const auto& e : pr.rec.of(VC_PAIR_PULSE_UNMATCHED)) {
    for (unsigned c = 0; c < 2; c++) {
      if (e.missing_mask & (1u << c)) {
        ASSERT_TRUE(dropped_frames[c].count(e.seq)) << "seq " << e.seq << " cam " << c;
      }
    }
  }
  auto s = pr.stats();
  uint64_t complete = 0;
  for (int i = 0; i < n; i++) {
    uint64_t seq = 1000 + (uint64_t)i;
    if (!dropped_pulses.count(seq) && !dropped_frames[0].count(seq) && !dropped_frames[1].count(seq))
      complete++;
  }
  for (unsigned c = 0; c < 2; c++) {
    EXPECT_EQ(s.frames_without_pulse[c], expect_unmatched_frames[c]) << "cam " << c;
    EXPECT_EQ(s.pulses_without_frame[c], expect_missing[c]) << "cam " << c;
    EXPECT_LE(s.error_max_ns[c], 500000);
    EXPECT_GE(s.error_min_ns[c], -500000);
  }
  EXPECT_EQ(s.complete, complete);
  EXPECT_EQ(pr.rec.of(VC_PAIR_COMPLETE).size(), complete);
  EXPECT_EQ(s.pulses, (uint64_t)n - dropped_pulses.size());
  EXPECT_EQ(s.overflow, 0u);
  EXPECT_EQ(matched, s.matched[0] + s.matched[1]);
}

INSTANTIATE_TEST_SUITE_P(
    Synthetic, PairingRun,
    ::testing::Values(Scenario{1, 0.0, 0.0, 0, 0},                 // clean: every pulse complete
                      Scenario{2, 0.05, 0.0, 2 * kMs, 1 * kMs},    // lost datagrams
                      Scenario{3, 0.0, 0.05, 2 * kMs, 1 * kMs},    // camera hiccups
                      Scenario{4, 0.05, 0.05, 12 * kMs, 3 * kMs},  // pulses often after their frames
                      Scenario{5, 0.1, 0.1, 3 * kMs, 14 * kMs},    // frames late (slow pipeline)
                      Scenario{6, 0.2, 0.2, 30 * kMs, 30 * kMs}),  // everything out of order
    [](const ::testing::TestParamInfo<Scenario>& info) { return "seed" + std::to_string(info.param.seed); });
