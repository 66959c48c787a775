#include "voxcap/assemble/assembler.hpp"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "voxcap/assemble/merge_stage.hpp"
#include "voxcap/rle.h"

namespace vc::assemble {
namespace {

constexpr uint64_t kVoxels = 4096 + 13;  // not a multiple of 8 on purpose

std::vector<uint8_t> random_bits(uint32_t seed, double density) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution bit(density);
  std::vector<uint8_t> b((kVoxels + 7) / 8, 0);
  for (uint64_t i = 0; i < kVoxels; i++)
    if (bit(rng)) b[i / 8] |= uint8_t(1u << (i % 8));
  return b;
}

std::vector<uint8_t> encode(const std::vector<uint8_t>& bits) {
  std::vector<uint8_t> out(vc_rle_max_encoded_size(kVoxels));
  size_t len = 0;
  EXPECT_EQ(vc_rle_encode(bits.data(), kVoxels, out.data(), out.size(), &len), 0);
  out.resize(len);
  return out;
}

PartialHull hull(uint16_t node, uint64_t seq, const std::vector<uint8_t>& bits, uint64_t t = 1000) {
  PartialHull h;
  h.node_id = node;
  h.seq = seq;
  h.t_trigger_ns = t;
  h.t_received_ns = t + 100;
  h.grid_id = 5;
  h.voxel_count = kVoxels;
  h.rle = encode(bits);
  return h;
}

AssemblerOptions opts(MissingPolicy policy = MissingPolicy::Drop) {
  AssemblerOptions o;
  o.nodes = {1, 2, 3};
  o.grid_id = 5;
  o.voxel_count = kVoxels;
  o.deadline_ns = 50'000;
  o.policy = policy;
  o.max_pending = 4;
  return o;
}

TEST(Assembler, MergesWhenEveryNodeReportedAndEqualsTheBitsetAnd) {
  Assembler a(opts());
  auto b1 = random_bits(1, 0.7), b2 = random_bits(2, 0.6), b3 = random_bits(3, 0.8);
  std::vector<MergedFrame> out;
  a.add(hull(1, 10, b1), 0, out);
  a.add(hull(3, 10, b3), 0, out);
  EXPECT_TRUE(out.empty());
  a.add(hull(2, 10, b2), 0, out);
  ASSERT_EQ(out.size(), 1u);
  std::vector<uint8_t> expect(b1.size());
  for (size_t i = 0; i < expect.size(); i++) expect[i] = b1[i] & b2[i] & b3[i];
  EXPECT_EQ(out[0].rle, encode(expect));
  uint64_t pop = 0;
  for (uint64_t i = 0; i < kVoxels; i++) pop += (expect[i / 8] >> (i % 8)) & 1;
  EXPECT_EQ(out[0].occupied, pop);
  EXPECT_FALSE(out[0].degraded);
  EXPECT_EQ(out[0].present, (std::vector<uint16_t>{1, 2, 3}));
  EXPECT_EQ(a.stats().complete, 1u);
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Assembler, DeadlineDropsOrDegradesByPolicy) {
  for (MissingPolicy policy : {MissingPolicy::Drop, MissingPolicy::Degraded}) {
    Assembler a(opts(policy));
    std::vector<MergedFrame> out;
    a.add(hull(1, 7, random_bits(1, 0.5)), 0, out);
    a.add(hull(2, 7, random_bits(2, 0.5)), 0, out);
    a.poll(1000 + 49'999, out);
    EXPECT_TRUE(out.empty());
    a.poll(1000 + 50'000, out);
    if (policy == MissingPolicy::Drop) {
      EXPECT_TRUE(out.empty());
      EXPECT_EQ(a.stats().dropped, 1u);
    } else {
      ASSERT_EQ(out.size(), 1u);
      EXPECT_TRUE(out[0].degraded);
      EXPECT_EQ(out[0].missing, (std::vector<uint16_t>{3}));
      EXPECT_EQ(a.stats().degraded, 1u);
    }
    EXPECT_EQ(a.stats().nodes.at(3).missing, 1u);
  }
}

// What the assembly thread waits for when no message comes: the earliest pending frame's deadline,
// none when nothing is pending.
TEST(Assembler, NextDeadlineIsTheEarliestPendingFramesDeadline) {
  Assembler a(opts(MissingPolicy::Degraded));
  std::vector<MergedFrame> out;
  EXPECT_EQ(a.next_deadline_ns(), 0u);
  a.add(hull(1, 8, random_bits(1, 0.5), 3000), 0, out);
  a.add(hull(3, 7, random_bits(3, 0.5), 2000), 0, out);
  EXPECT_EQ(a.next_deadline_ns(), 2000u + 50'000u);
  a.poll(2000 + 50'000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(a.next_deadline_ns(), 3000u + 50'000u);
  a.add(hull(2, 8, random_bits(2, 0.5), 3000), 0, out);
  a.add(hull(3, 8, random_bits(3, 0.5), 3000), 0, out);
  EXPECT_EQ(a.next_deadline_ns(), 0u);
}

TEST(Assembler, StoppedNodeIsNotWaitedForButMarksTheFrame) {
  Assembler a(opts(MissingPolicy::Degraded));
  a.set_running(2, false);
  std::vector<MergedFrame> out;
  a.add(hull(1, 3, random_bits(1, 0.5)), 0, out);
  a.add(hull(3, 3, random_bits(3, 0.5)), 0, out);
  ASSERT_EQ(out.size(), 1u);  // no deadline wait
  EXPECT_TRUE(out[0].degraded);
  EXPECT_EQ(out[0].missing, (std::vector<uint16_t>{2}));
}

TEST(Assembler, LateAndDuplicateAndForeignHullsAreCounted) {
  Assembler a(opts(MissingPolicy::Degraded));
  std::vector<MergedFrame> out;
  auto bits = random_bits(9, 0.5);
  a.add(hull(1, 20, bits), 0, out);
  EXPECT_FALSE(a.add(hull(1, 20, bits), 0, out));  // duplicate
  a.poll(1'000'000, out);                          // frame 20 resolved
  EXPECT_FALSE(a.add(hull(2, 20, bits), 0, out));  // late
  EXPECT_FALSE(a.add(hull(2, 19, bits), 0, out));  // older than resolved: late
  PartialHull wrong = hull(3, 21, bits);
  wrong.grid_id = 6;
  EXPECT_FALSE(a.add(wrong, 0, out));
  EXPECT_FALSE(a.add(hull(9, 21, bits), 0, out));  // not configured
  EXPECT_EQ(a.stats().nodes.at(1).rejected, 1u);
  EXPECT_EQ(a.stats().nodes.at(2).late, 2u);
  EXPECT_EQ(a.stats().nodes.at(3).rejected, 1u);
}

TEST(Assembler, MemoryIsBoundedWhenANodeStalls) {
  Assembler a(opts(MissingPolicy::Degraded));
  std::vector<MergedFrame> out;
  auto bits = random_bits(4, 0.5);
  // Node 3 never reports and time does not advance: pending frames are capped at max_pending.
  for (uint64_t seq = 0; seq < 1000; seq++) {
    a.add(hull(1, seq, bits), 0, out);
    a.add(hull(2, seq, bits), 0, out);
    ASSERT_LE(a.pending(), 4u);
  }
  EXPECT_EQ(a.stats().evicted, 996u);
  EXPECT_EQ(out.size(), 996u);
  for (size_t i = 1; i < out.size(); i++) EXPECT_LT(out[i - 1].seq, out[i].seq);
  a.flush(0, out);
  EXPECT_EQ(out.size(), 1000u);
  EXPECT_EQ(a.pending(), 0u);
}

// The attack of issue #13: one HULL (or FEATURES) with seq 2^62 and a pulse time of 0 made every later
// frame late. With pulsed_only the seq is refused (counted), and a pulse time written by a node never
// decides a deadline: the real frames go on merging complete.
TEST(Assembler, PulsedOnlyRefusesSeqsNeverPulsedAndKeepsMerging) {
  AssemblerOptions o = opts();
  o.pulsed_only = true;
  Assembler a(o);
  std::vector<MergedFrame> out;
  auto bits = random_bits(11, 0.5);
  vc_features f{};
  EXPECT_FALSE(a.add(hull(1, 5, bits), 0, out));  // nothing pulsed yet
  EXPECT_FALSE(a.add_features(1, 5, 0, f, 0, out));
  uint64_t t = 1'000'000'000;
  for (uint64_t seq = 1; seq <= 200; seq++, t += 16'666'667) {
    a.pulse(seq, t);
    if (seq == 50) {
      EXPECT_FALSE(a.add(hull(2, uint64_t{1} << 62, bits, 0), t, out));
      EXPECT_FALSE(a.add_features(3, 100000, 0, f, t, out));
      pipeline::Silhouette s;
      EXPECT_FALSE(a.add_silhouette(1, seq + 2, 0, s, t, out));
      // A pulsed seq whose node wrote a trigger time of 0: the deadline is the host's pulse time.
      EXPECT_TRUE(a.add(hull(2, seq, bits, 0), t, out));
      a.poll(t + 1000, out);
      EXPECT_EQ(a.pending(), 1u);
    } else {
      a.add(hull(2, seq, bits, t), t + 1000, out);
    }
    a.add(hull(1, seq, bits, t), t + 2000, out);
    a.add(hull(3, seq, bits, t), t + 3000, out);
    a.poll(t + 4000, out);
  }
  EXPECT_EQ(out.size(), 200u);
  EXPECT_EQ(a.stats().complete, 200u);
  EXPECT_EQ(a.stats().nodes.at(1).unpulsed, 3u);  // two before any pulse, one silhouette ahead
  EXPECT_EQ(a.stats().nodes.at(2).unpulsed, 1u);
  EXPECT_EQ(a.stats().nodes.at(3).unpulsed, 1u);
  for (const auto& [id, nc] : a.stats().nodes) EXPECT_EQ(nc.late, 0u);
  // A message one pulse ahead of the pulse's note (pulse_slack) is taken and waits for its pulse.
  EXPECT_TRUE(a.add(hull(1, 201, bits, 0), t, out));
  a.pulse(201, t);
  a.poll(t + 1000, out);
  EXPECT_EQ(a.pending(), 1u);
  a.poll(t + o.deadline_ns, out);
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Assembler, InvalidOptionsThrow) {
  AssemblerOptions o = opts();
  o.nodes = {1, 1};
  EXPECT_THROW(Assembler{o}, std::invalid_argument);
  o = opts();
  o.voxel_count = 0;
  EXPECT_THROW(Assembler{o}, std::invalid_argument);
}

vc_features features(uint16_t camera, float u) {
  vc_features f{};
  f.camera = camera;
  f.feature_count = 1;
  f.features[0].feature_id = 1;
  f.features[0].u = u;
  return f;
}

pipeline::Silhouette silhouette(uint16_t camera, uint16_t fg) {
  pipeline::Silhouette s;
  s.camera = camera;
  s.scale = 2;
  s.width = 8;
  s.height = 4;
  s.foreground = fg;
  s.rle = {static_cast<uint8_t>(32 - fg), static_cast<uint8_t>(fg)};  // the last fg pixels
  return s;
}

// A node's message about a later seq says its hull for an earlier one is not coming (its camera missed
// the pulse, it dropped the frame): the frame leaves on that message, not at its deadline, which in
// this test never comes (no poll, the deadline far away). A FEATURES of the same seq says nothing.
TEST(Assembler, ANodesLaterMessageResolvesTheFrameItSkippedWithoutTheDeadline) {
  for (MissingPolicy policy : {MissingPolicy::Degraded, MissingPolicy::Drop}) {
    AssemblerOptions o = opts(policy);
    o.deadline_ns = uint64_t{1} << 62;
    Assembler a(o);
    std::vector<MergedFrame> out;
    a.add(hull(1, 10, random_bits(1, 0.5)), 0, out);
    a.add(hull(2, 10, random_bits(2, 0.5)), 0, out);
    EXPECT_TRUE(a.add_features(3, 10, 1000, features(0, 1), 0, out));
    EXPECT_TRUE(out.empty()) << "node 3 is still on seq 10: its hull may come";
    EXPECT_EQ(a.pending(), 1u);
    a.add(hull(1, 11, random_bits(1, 0.5)), 0, out);
    EXPECT_TRUE(a.add_features(3, 11, 1000, features(0, 1), 0, out));  // node 3 is past seq 10
    EXPECT_EQ(a.pending(), 1u) << "frame 10 resolved, frame 11 waits";
    EXPECT_EQ(a.stats().nodes.at(3).missing, 1u);
    if (policy == MissingPolicy::Degraded) {
      ASSERT_EQ(out.size(), 1u);
      EXPECT_EQ(out[0].seq, 10u);
      EXPECT_TRUE(out[0].degraded);
      EXPECT_EQ(out[0].missing, (std::vector<uint16_t>{3}));
      ASSERT_NE(out[0].node(3), nullptr);
      EXPECT_EQ(out[0].node(3)->features.size(), 1u) << "what node 3 sent for seq 10 goes with it";
    } else {
      EXPECT_TRUE(out.empty());
      EXPECT_EQ(a.stats().dropped, 1u);
    }
    EXPECT_FALSE(a.add(hull(3, 10, random_bits(3, 0.5)), 0, out)) << "had it come after all: late";
    EXPECT_EQ(a.stats().nodes.at(3).late, 1u);
  }
}

// The edges' messages arrive in seq order per node, interleaved across nodes in any way, and each
// node skips some frames. Frames leave in seq order as soon as every node has moved past them, each
// missing exactly the nodes that skipped it; only the last frames wait (for the stop). Before, a frame
// a node skipped waited for its deadline while the complete frames after it left first.
TEST(Assembler, FramesLeaveInSeqOrderEachWhenEveryNodeMovedPastIt) {
  AssemblerOptions o = opts(MissingPolicy::Degraded);
  o.deadline_ns = uint64_t{1} << 62;
  o.max_pending = 64;
  Assembler a(o);
  std::mt19937 rng(7);
  std::bernoulli_distribution skip(0.15);
  constexpr uint64_t kFrames = 300;
  std::map<uint16_t, std::vector<uint64_t>> sent;  // per node, the seqs it sends a hull for
  std::map<uint64_t, std::vector<uint16_t>> skipped;
  for (uint16_t n : {1, 2, 3})
    for (uint64_t seq = 0; seq < kFrames; seq++) {
      if (seq + 1 < kFrames && skip(rng))
        skipped[seq].push_back(n);
      else
        sent[n].push_back(seq);
    }
  auto bits = random_bits(5, 0.5);
  std::vector<MergedFrame> out;
  std::map<uint16_t, size_t> next;
  for (;;) {
    std::vector<uint16_t> left;
    for (uint16_t n : {1, 2, 3})
      if (next[n] < sent[n].size()) left.push_back(n);
    if (left.empty()) break;
    const uint16_t n = left[std::uniform_int_distribution<size_t>(0, left.size() - 1)(rng)];
    ASSERT_TRUE(a.add(hull(n, sent[n][next[n]++], bits), 0, out));
  }
  EXPECT_EQ(a.pending(), 0u) << "the last seq is sent by every node";
  size_t k = 0;
  for (uint64_t seq = 0; seq < kFrames; seq++) {
    const std::vector<uint16_t>& missing = skipped[seq];
    if (missing.size() == 3) continue;  // no node sent it: there is no frame
    ASSERT_LT(k, out.size());
    EXPECT_EQ(out[k].seq, seq);
    EXPECT_EQ(out[k].missing, missing) << "seq " << seq;
    EXPECT_EQ(out[k].degraded, !missing.empty());
    k++;
  }
  EXPECT_EQ(k, out.size());
  EXPECT_GT(a.stats().degraded, 50u);
  EXPECT_EQ(a.stats().evicted, 0u);
}

TEST(Assembler, SilhouettesJoinTheFrameOfTheirSeqBoundedAndLateOnesCounted) {
  Assembler a(opts());
  std::vector<MergedFrame> out;
  EXPECT_TRUE(a.add_silhouette(2, 10, 1000, silhouette(1, 5), 0, out));  // before any hull of seq 10
  a.add(hull(1, 10, random_bits(1, 0.5)), 0, out);
  EXPECT_TRUE(a.add_silhouette(2, 10, 1000, silhouette(0, 7), 0, out));
  EXPECT_FALSE(a.add_silhouette(2, 10, 1000, silhouette(0, 9), 0, out)) << "camera 0 twice for one frame";
  EXPECT_FALSE(a.add_silhouette(2, 10, 1000, silhouette(VC_PROTO_MAX_CAMERAS, 1), 0, out));
  EXPECT_FALSE(a.add_silhouette(9, 10, 1000, silhouette(0, 1), 0, out)) << "not a configured node";
  EXPECT_GT(a.pending_bytes(), 0u);
  a.add(hull(2, 10, random_bits(2, 0.5)), 0, out);
  a.add(hull(3, 10, random_bits(3, 0.5)), 0, out);
  ASSERT_EQ(out.size(), 1u) << "complete on the last hull: silhouettes are not waited for";
  const pipeline::NodePart* n2 = out[0].node(2);
  ASSERT_NE(n2, nullptr);
  ASSERT_EQ(n2->silhouettes.size(), 2u);
  EXPECT_EQ(n2->silhouettes[0].camera, 1);
  EXPECT_EQ(n2->silhouettes[0].foreground, 5u);
  EXPECT_EQ(n2->silhouettes[1].camera, 0);
  EXPECT_EQ(n2->silhouettes[1].rle, (std::vector<uint8_t>{25, 7}));
  EXPECT_EQ(n2->silhouettes[1].width, 8);
  EXPECT_EQ(n2->silhouettes[1].scale, 2);
  EXPECT_TRUE(out[0].node(1)->silhouettes.empty());
  EXPECT_FALSE(a.add_silhouette(2, 10, 1000, silhouette(1, 1), 0, out)) << "frame 10 is gone: late";
  const NodeCounters& c = a.stats().nodes.at(2);
  EXPECT_EQ(c.silhouettes, 2u);
  EXPECT_EQ(c.silhouettes_rejected, 2u);
  EXPECT_EQ(c.silhouettes_late, 1u);
  EXPECT_EQ(a.pending(), 0u);
}

TEST(Assembler, FeaturesJoinTheFrameOfTheirSeqWithoutHoldingItBack) {
  Assembler a(opts());
  std::vector<MergedFrame> out;
  EXPECT_TRUE(a.add_features(1, 10, 1000, features(0, 1.5f), 0, out));  // before any hull of seq 10
  a.add(hull(1, 10, random_bits(1, 0.5)), 0, out);
  EXPECT_TRUE(a.add_features(1, 10, 1000, features(1, 2.5f), 0, out));
  EXPECT_FALSE(a.add_features(1, 10, 1000, features(1, 9.5f), 0, out)) << "camera 1 twice for one frame";
  EXPECT_FALSE(a.add_features(1, 10, 1000, features(VC_PROTO_MAX_CAMERAS, 1), 0, out));
  a.add(hull(2, 10, random_bits(2, 0.5)), 0, out);
  a.add(hull(3, 10, random_bits(3, 0.5)), 0, out);
  ASSERT_EQ(out.size(), 1u) << "complete on the last hull: features are not waited for";
  const pipeline::NodePart* n1 = out[0].node(1);
  ASSERT_NE(n1, nullptr);
  ASSERT_EQ(n1->features.size(), 2u);
  EXPECT_EQ(n1->features[0].camera, 0);
  EXPECT_FLOAT_EQ(n1->features[1].features[0].u, 2.5f);
  EXPECT_TRUE(out[0].node(2)->features.empty());
  EXPECT_EQ(out[0].t_trigger_ns, 1000u) << "a frame made by FEATURES keeps their trigger time";
  EXPECT_EQ(out[0].t_first_rx_ns, 1100u) << "receive times are the hulls'";
  EXPECT_FALSE(a.add_features(3, 10, 1000, features(0, 0), 0, out)) << "frame 10 is gone: late";
  EXPECT_FALSE(a.add_features(9, 11, 1000, features(0, 0), 0, out)) << "not a configured node";
  EXPECT_EQ(a.stats().nodes.at(1).features, 2u);
  EXPECT_EQ(a.stats().nodes.at(3).features_late, 1u);
  EXPECT_EQ(a.stats().nodes.at(1).features_rejected, 2u);
}

TEST(Assembler, FramesCarryEveryNodesPartialHullAndTheStatsThatCameBeforeThem) {
  Assembler a(opts(MissingPolicy::Degraded));
  std::vector<MergedFrame> out;
  vc_stats st{};
  st.frames = 60;
  a.add_stats(2, st);
  a.add_stats(9, st);  // not configured: ignored
  auto b1 = random_bits(1, 0.5), b3 = random_bits(3, 0.5);
  a.add(hull(1, 4, b1), 0, out);
  a.add(hull(3, 4, b3), 0, out);
  a.poll(1'000'000, out);
  ASSERT_EQ(out.size(), 1u);
  const MergedFrame& f = out[0];
  ASSERT_EQ(f.nodes.size(), 3u) << "node 2 sent no hull, but its STATS ride on this frame";
  EXPECT_EQ(f.nodes[0].node_id, 1);
  EXPECT_EQ(f.nodes[1].node_id, 2);
  EXPECT_EQ(f.nodes[2].node_id, 3);
  EXPECT_EQ(f.nodes[0].rle, encode(b1));
  EXPECT_TRUE(f.nodes[0].has_hull);
  EXPECT_FALSE(f.nodes[1].has_hull);
  ASSERT_EQ(f.nodes[1].stats.size(), 1u);
  EXPECT_EQ(f.nodes[1].stats[0].frames, 60u);
  EXPECT_EQ(f.missing, (std::vector<uint16_t>{2}));
  a.add(hull(1, 5, b1), 0, out);
  a.poll(2'000'000, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].node(2), nullptr) << "STATS go with one frame only";
}

TEST(Assembler, UnmergedFramesAreMergedLaterToTheSameHull) {
  AssemblerOptions o = opts();
  o.merge = false;
  Assembler a(o), b(opts());
  std::vector<MergedFrame> out, ref;
  for (uint16_t n = 1; n <= 3; n++) {
    auto bits = random_bits(40 + n, 0.7);
    a.add(hull(n, 8, bits), 0, out);
    b.add(hull(n, 8, bits), 0, ref);
  }
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(ref.size(), 1u);
  EXPECT_FALSE(out[0].merged);
  EXPECT_TRUE(out[0].rle.empty());
  EXPECT_TRUE(ref[0].merged);
  MergeStage stage;
  EXPECT_EQ(stage.name(), "merge");
  stage.process(out[0]);
  EXPECT_TRUE(out[0].merged);
  EXPECT_EQ(out[0].rle, ref[0].rle);
  EXPECT_EQ(out[0].occupied, ref[0].occupied);
  EXPECT_GE(out[0].t_merged_ns, out[0].t_assembled_ns);
  pipeline::Frame empty;
  empty.voxel_count = kVoxels;
  EXPECT_THROW(stage.process(empty), std::runtime_error);
}

TEST(Intersect, AnyNumberOfHullsEqualsTheBitsetAnd) {
  // 70 hulls: more than one vc_rle_and_n pass takes (VC_RLE_AND_MAX_STREAMS).
  std::vector<std::vector<uint8_t>> bits, rles;
  for (uint32_t k = 0; k < 70; k++) {
    bits.push_back(random_bits(100 + k, 0.995));
    rles.push_back(encode(bits.back()));
  }
  std::vector<uint8_t> out, scratch;
  for (size_t n : {size_t{1}, size_t{2}, size_t{3}, size_t{8}, size_t{VC_RLE_AND_MAX_STREAMS},
                   size_t{VC_RLE_AND_MAX_STREAMS + 1}, size_t{70}}) {
    SCOPED_TRACE(n);
    std::vector<const std::vector<uint8_t>*> in;
    std::vector<uint8_t> expect = bits[0];
    for (size_t k = 0; k < n; k++) {
      in.push_back(&rles[k]);
      for (size_t i = 0; i < expect.size(); i++) expect[i] &= bits[k][i];
    }
    intersect(in, out, scratch);
    EXPECT_EQ(out, encode(expect));
  }
  // Worst-case streams (every voxel its own run), with a fresh scratch buffer.
  std::vector<uint8_t> alt((kVoxels + 7) / 8, 0x55);
  std::vector<uint8_t> alt_rle = encode(alt), fresh;
  intersect({&alt_rle, &alt_rle, &alt_rle}, out, fresh);
  EXPECT_EQ(out, alt_rle);
}

TEST(Intersect, RejectsNoHullsMalformedAndMismatchedStreams) {
  std::vector<uint8_t> out, scratch;
  EXPECT_THROW(intersect({}, out, scratch), std::runtime_error);
  const std::vector<uint8_t> ok = encode(random_bits(1, 0.5));
  const std::vector<uint8_t> bad{0x02, 0x00, 0x03}, shorter{0x05};
  EXPECT_THROW(intersect({&bad}, out, scratch), std::runtime_error);
  EXPECT_THROW(intersect({&ok, &bad}, out, scratch), std::runtime_error);
  EXPECT_THROW(intersect({&ok, &ok, &shorter}, out, scratch), std::runtime_error);
}

}  // namespace
}  // namespace vc::assemble
