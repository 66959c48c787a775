// The hil figures on synthetic timestamp streams: a clean train, a dropped pulse, an extra glitch
// edge, jitter, an offset between output and input, a wrapping 32-bit counter; frames against pulses.
#include "voxcap/hil/measure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace vc::hil {
namespace {

constexpr double kRate = 60;
constexpr int64_t kPeriod = 16666667;  // ns at 60 Hz
constexpr int64_t kT0 = 5'000'000'000;

std::vector<Stamp> train(size_t n, int64_t t0 = kT0, uint64_t seq0 = 0) {
  std::vector<Stamp> v;
  for (size_t i = 0; i < n; ++i) v.push_back({seq0 + i, t0 + static_cast<int64_t>(i) * kPeriod});
  return v;
}

TEST(Percentiles, NearestRankOnSortedValues) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  const Percentiles p = percentiles(v);
  EXPECT_EQ(p.n, 100u);
  EXPECT_EQ(p.min, 1);
  EXPECT_EQ(p.p50, 50);
  EXPECT_EQ(p.p95, 95);
  EXPECT_EQ(p.p99, 99);
  EXPECT_EQ(p.max, 100);
}

TEST(Percentiles, EmptyIsNanAndNonFiniteValuesAreLeftOut) {
  EXPECT_TRUE(std::isnan(percentiles({}).p50));
  const Percentiles p = percentiles({NAN, 3.0, INFINITY});
  EXPECT_EQ(p.n, 1u);
  EXPECT_EQ(p.max, 3.0);
}

TEST(MatchTrain, CleanTrainEveryPulseSeenZeroJitter) {
  const auto sent = train(120);
  const TrainResult r = match_train(sent, sent, {kRate});
  EXPECT_EQ(r.sent, 120u);
  EXPECT_EQ(r.seen, 120u);
  EXPECT_EQ(r.matched, 120u);
  EXPECT_EQ(r.missed, 0u);
  EXPECT_EQ(r.extra, 0u);
  EXPECT_EQ(r.seq_gaps, 0u);
  EXPECT_EQ(r.jitter_us.n, 119u);
  EXPECT_LT(r.jitter_us.max, 0.001);
  EXPECT_NEAR(r.period_us, 16666.667, 0.01);
  EXPECT_EQ(judge_train(r, 120).status, Status::Pass);
}

TEST(MatchTrain, DroppedPulseIsMissedByItsSeqAndTheCounterGap) {
  const auto sent = train(60);
  auto seen = sent;
  seen.erase(seen.begin() + 17);  // the input never saw pulse 17: its counter skips one
  const TrainResult r = match_train(sent, seen, {kRate});
  EXPECT_EQ(r.matched, 59u);
  EXPECT_EQ(r.missed, 1u);
  ASSERT_EQ(r.missed_seqs.size(), 1u);
  EXPECT_EQ(r.missed_seqs[0], 17u);
  EXPECT_EQ(r.extra, 0u);
  EXPECT_EQ(r.seq_gaps, 1u);
  // The interval over the gap is two periods: whole periods are not jitter.
  EXPECT_LT(r.jitter_us.max, 0.001);
  const Verdict v = judge_train(r, 60);
  EXPECT_EQ(v.status, Status::Fail);
  EXPECT_NE(v.reason.find("1 missed (seq 17)"), std::string::npos) << v.reason;
}

TEST(MatchTrain, ExtraGlitchEdgeIsExtraAndDoesNotStealAPulse) {
  const auto sent = train(60);
  auto seen = sent;
  // A glitch 2 ms after pulse 30 (inside its window) and one half-way between 40 and 41.
  seen.push_back({999, sent[30].t_ns + 2'000'000});
  seen.push_back({1000, sent[40].t_ns + kPeriod / 2});
  const TrainResult r = match_train(sent, seen, {kRate});
  EXPECT_EQ(r.matched, 60u);
  EXPECT_EQ(r.missed, 0u);
  EXPECT_EQ(r.extra, 2u);
  ASSERT_EQ(r.extra_at_us.size(), 2u);
  EXPECT_EQ(r.extra_at_us[0], (30 * kPeriod + 2'000'000) / 1000);
  EXPECT_LT(r.jitter_us.max, 0.001);  // the real edges were the ones matched
  EXPECT_EQ(judge_train(r, 60).status, Status::Fail);
}

TEST(MatchTrain, JitterPercentilesOfTheSeenEdges) {
  const auto sent = train(1000);
  auto seen = sent;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int64_t> noise(-50'000, 50'000);  // ±50 us on every edge
  for (Stamp& s : seen) s.t_ns += noise(rng);
  seen[500].t_ns += 1'000'000;  // one edge 1 ms late: two intervals off by ~1 ms
  const TrainResult r = match_train(sent, seen, {kRate});
  EXPECT_EQ(r.matched, 1000u);
  EXPECT_EQ(r.missed + r.extra, 0u);
  EXPECT_EQ(r.jitter_us.n, 999u);
  EXPECT_GT(r.jitter_us.p50, 10);
  EXPECT_LT(r.jitter_us.p99, 100.001);  // two noise draws at most
  EXPECT_GT(r.jitter_us.max, 900);
  EXPECT_LT(r.jitter_us.max, 1100.001);
  EXPECT_EQ(judge_train(r, 1000).status, Status::Pass);
  const Verdict limited = judge_train(r, 1000, 500);
  EXPECT_EQ(limited.status, Status::Fail);
  EXPECT_NE(limited.reason.find("jitter max"), std::string::npos) << limited.reason;
}

TEST(MatchTrain, ConstantOffsetBetweenOutputAndInputIsRemoved) {
  const auto sent = train(100);
  auto seen = train(100, kT0 + 7'300'000);  // the input sees each edge 7.3 ms after the host's stamp
  seen.erase(seen.begin() + 3);
  const TrainResult r = match_train(sent, seen, {kRate});
  EXPECT_EQ(r.matched, 99u);
  EXPECT_EQ(r.missed, 1u);
  EXPECT_EQ(r.missed_seqs.at(0), 3u);
  EXPECT_EQ(r.extra, 0u);
  EXPECT_NEAR(r.offset_us, 7300, 0.01);
  EXPECT_LT(r.spread_us.max, 0.01);
}

TEST(MatchTrain, WrappingThirtyTwoBitCounterIsNoGap) {
  const auto sent = train(50);
  auto seen = train(50, kT0, 0xffffffffull - 20);  // a raw kernel counter crossing 2^32
  for (Stamp& s : seen) s.seq &= 0xffffffffull;
  TrainOptions o{kRate};
  o.seq_bits = 32;
  TrainResult r = match_train(sent, seen, o);
  EXPECT_EQ(r.seq_gaps, 0u);
  EXPECT_EQ(r.matched, 50u);
  seen.erase(seen.begin() + 25);  // a real gap just after the wrap still counts
  r = match_train(sent, seen, o);
  EXPECT_EQ(r.seq_gaps, 1u);
  EXPECT_EQ(r.missed, 1u);
}

TEST(MatchTrain, NothingSeenIsAllMissedAndSaysToCheckTheWiring) {
  const TrainResult r = match_train(train(10), {}, {kRate});
  EXPECT_EQ(r.missed, 10u);
  EXPECT_TRUE(std::isnan(r.jitter_us.p50));
  const Verdict v = judge_train(r, 10);
  EXPECT_EQ(v.status, Status::Fail);
  EXPECT_NE(v.reason.find("wired"), std::string::npos);
}

TEST(MatchTrain, UnorderedInputAndBadOptions) {
  auto sent = train(20);
  auto seen = sent;
  std::swap(seen[3], seen[9]);
  EXPECT_EQ(match_train(sent, seen, {kRate}).matched, 20u);
  EXPECT_THROW(match_train(sent, seen, {0}), std::invalid_argument);
  TrainOptions o{kRate};
  o.tolerance = 0.5;
  EXPECT_THROW(match_train(sent, seen, o), std::invalid_argument);
}

TEST(AlignFrames, EveryFramePairsWithItsPulseAtTheLatency) {
  const auto pulses = train(100);
  std::vector<FrameStamp> frames;
  for (int c = 0; c < 2; ++c)
    for (const Stamp& p : pulses) frames.push_back({c, p.seq, p.t_ns + 4'000'000 + c * 10'000});
  AlignOptions o{kRate, 4000, 0.4, 2};
  const AlignResult r = align_frames(pulses, frames, o);
  ASSERT_EQ(r.cameras.size(), 2u);
  EXPECT_EQ(r.pulses, 100u);
  EXPECT_EQ(r.cameras[0].paired, 100u);
  EXPECT_EQ(r.cameras[1].paired, 100u);
  EXPECT_EQ(r.cameras[0].unpaired + r.cameras[1].unpaired, 0u);
  EXPECT_NEAR(r.cameras[0].offset_us.p50, 4000, 0.01);
  EXPECT_NEAR(r.cameras[1].offset_us.p99, 4010, 0.01);
  EXPECT_EQ(judge_alignment(r, o).status, Status::Pass);
  EXPECT_EQ(judge_alignment(r, o, 5).status, Status::Fail);  // camera 1 is 10 us off the latency
}

TEST(AlignFrames, DroppedFrameSpuriousFrameAndDoubleFrame) {
  const auto pulses = train(60);
  std::vector<FrameStamp> frames;
  for (const Stamp& p : pulses)
    if (p.seq != 20) frames.push_back({0, p.seq, p.t_ns + 1'000'000});  // pulse 20: no frame
  frames.push_back({0, 100, pulses[30].t_ns + kPeriod / 2});            // a free-running frame
  frames.push_back({0, 101, pulses[40].t_ns + 1'200'000});              // a second frame on pulse 40
  AlignOptions o{kRate, 1000, 0.25, 1};
  const AlignResult r = align_frames(pulses, frames, o);
  const CameraAlignment& c = r.cameras.at(0);
  EXPECT_EQ(c.frames, 61u);
  EXPECT_EQ(c.paired, 59u);
  EXPECT_EQ(c.unpaired, 2u);
  EXPECT_EQ(c.duplicate, 1u);
  EXPECT_EQ(c.pulses_without_frame, 1u);
  const Verdict v = judge_alignment(r, o);
  EXPECT_EQ(v.status, Status::Fail);
  EXPECT_NE(v.reason.find("2 of 61 frames without a pulse"), std::string::npos) << v.reason;
  EXPECT_NE(v.reason.find("1 pulses without a frame"), std::string::npos) << v.reason;
}

TEST(AlignFrames, CameraWithoutFramesFailsAndPulsesOutsideTheRunDoNotCount) {
  const auto pulses = train(30);
  std::vector<FrameStamp> frames;
  for (size_t i = 5; i < 25; ++i) frames.push_back({0, i, pulses[i].t_ns});
  AlignOptions o{kRate, 0, 0.4, 2};
  const AlignResult r = align_frames(pulses, frames, o);
  EXPECT_EQ(r.cameras[0].pulses_without_frame, 0u);  // pulses 0-4 and 25-29 are outside its run
  EXPECT_EQ(r.cameras[1].frames, 0u);
  EXPECT_EQ(judge_alignment(r, o).status, Status::Fail);
  EXPECT_THROW(align_frames(pulses, {{2, 0, 0}}, o), std::invalid_argument);
}

TEST(JudgeSmoke, NamesTheMissingNodesAndAStoppedMerge) {
  SmokeFigures f;
  f.nodes = 3;
  f.nodes_connected = 3;
  f.running = true;
  f.frames = 300;
  f.complete = 300;
  EXPECT_EQ(judge_smoke(f).status, Status::Pass);
  f.nodes_connected = 2;
  f.nodes_missing = {"pi-c"};
  f.merging_stopped = true;
  const Verdict v = judge_smoke(f);
  EXPECT_EQ(v.status, Status::Fail);
  EXPECT_NE(v.reason.find("2 of 3 nodes connected (missing: pi-c)"), std::string::npos) << v.reason;
  EXPECT_NE(v.reason.find("stopped merging"), std::string::npos) << v.reason;
}

}  // namespace
}  // namespace vc::hil
