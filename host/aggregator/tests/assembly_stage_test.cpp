// The assembly stage between the session thread and the pipeline: posting never waits, a full queue
// drops and counts per node, frames leave in order, stop() flushes what is pending.
#include "voxcap/aggregator/assembly_stage.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "voxcap/base/clock.hpp"
#include "voxcap/rle.h"

namespace vc::aggregator {
namespace {

using namespace std::chrono_literals;

// A consumer that waits at a gate before each frame.
struct Gate : pipeline::Stage {
  std::mutex mu;
  std::condition_variable cv;
  bool open = false;
  std::vector<uint64_t> seqs;
  std::vector<size_t> features;
  std::vector<uint64_t> t_trigger;
  std::string name() const override { return "gate"; }
  void process(pipeline::Frame& f) override {
    std::unique_lock<std::mutex> l(mu);
    cv.wait(l, [&] { return open; });
    seqs.push_back(f.seq);
    t_trigger.push_back(f.t_trigger_ns);
    features.push_back(f.node(1) ? f.node(1)->features.size() : 0);
  }
  void release() {
    {
      std::lock_guard<std::mutex> g(mu);
      open = true;
    }
    cv.notify_all();
  }
};

assemble::AssemblerOptions options() {
  assemble::AssemblerOptions o;
  o.nodes = {1, 2};
  o.grid_id = 7;
  o.voxel_count = 64;
  o.deadline_ns = 1'000'000'000'000ull;  // never: frames complete by their hulls, or at stop
  return o;
}

assemble::PartialHull hull(uint16_t node, uint64_t seq) {
  std::vector<uint8_t> bits(8, 0xFF), rle(vc_rle_max_encoded_size(64));
  size_t len = 0;
  EXPECT_EQ(vc_rle_encode(bits.data(), 64, rle.data(), rle.size(), &len), 0);
  rle.resize(len);
  assemble::PartialHull h;
  h.node_id = node;
  h.seq = seq;
  h.t_trigger_ns = vc::monotonic_ns();  // the deadline counts from the pulse
  h.t_received_ns = h.t_trigger_ns;
  h.grid_id = 7;
  h.voxel_count = 64;
  h.occupied = 64;
  h.rle = rle;
  return h;
}

TEST(AssemblyStage, PostingNeverWaitsAndAFullQueueDropsCountedPerNode) {
  pipeline::Pipeline p(pipeline::StageContext{});
  Gate& gate = p.tap(std::make_unique<Gate>(), {1, pipeline::Overflow::Block});
  p.start();
  std::vector<std::string> warnings;
  AssemblyStage a(options(), {8, 1}, p, [&](log::Level level, const std::string& line) {
    if (level == log::Level::warn) warnings.push_back(line);
  });
  a.set_running(1, true);
  a.set_running(2, true);
  a.start();
  // The gate is shut: the pipeline holds one frame in the stage and one in its queue, the assembly
  // thread waits to push the third; then its own queue fills up.
  auto t0 = std::chrono::steady_clock::now();
  uint64_t accepted = 0, refused = 0;
  vc_features f{};
  f.feature_count = 1;
  for (uint64_t seq = 1; seq <= 200; seq++) {
    a.post_features(1, seq, vc::monotonic_ns(), f);
    bool h1 = a.post_hull(hull(1, seq));
    bool h2 = a.post_hull(hull(2, seq));
    (h1 && h2 ? accepted : refused)++;  // a frame needs both hulls
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s) << "the session thread never waits";
  EXPECT_GT(refused, 150u);
  EXPECT_GE(accepted, 2u) << "the queue's 8 places hold the first two seqs";
  std::map<uint16_t, uint64_t> drops = a.drops();
  EXPECT_GT(drops[1], 0u);
  EXPECT_GT(drops[2], 0u);
  pipeline::StageReport r = a.report();
  EXPECT_EQ(r.name, "assemble");
  EXPECT_EQ(r.overflow, pipeline::Overflow::DropNewest);
  EXPECT_EQ(r.queue.dropped, drops[1] + drops[2]);
  EXPECT_LE(r.queue.max_depth, 8u);
  ASSERT_EQ(warnings.size(), 1u) << "one line, not one per message";
  EXPECT_NE(warnings[0].find("queue full"), std::string::npos);
  gate.release();
  a.stop();
  p.stop();
  // The seqs whose two hulls were accepted became frames (a seq that lost a hull is dropped at
  // stop by the policy, Drop), in seq order, each with node 1's FEATURES.
  ASSERT_EQ(gate.seqs.size(), accepted);
  for (size_t i = 1; i < gate.seqs.size(); i++) EXPECT_LT(gate.seqs[i - 1], gate.seqs[i]);
  EXPECT_EQ(gate.seqs[0], 1u);
  EXPECT_EQ(gate.features[0], 1u);
  EXPECT_EQ(a.stats().complete + a.stats().degraded, gate.seqs.size());
  EXPECT_FALSE(a.post_hull(hull(1, 999))) << "stopped";
}

// Per-node bounds (issue #13): one node that floods the queue with big messages is held to its share
// of bytes; the other node's messages still get in, and the queue's memory stays bounded.
TEST(AssemblyStage, ANodeOverItsShareOfBytesIsDroppedAndTheOthersGetIn) {
  pipeline::Pipeline p(pipeline::StageContext{});
  Gate& gate = p.tap(std::make_unique<Gate>(), {1, pipeline::Overflow::Block});
  p.start();
  AssemblyOptions ao;
  ao.queue = 1024;
  ao.max_node_bytes = 64 * 1024;
  AssemblyStage a(options(), ao, p, {});
  a.set_running(1, true);
  a.set_running(2, true);
  a.start();
  // Node 1's hulls carry 8 KiB of RLE each (the stage counts bytes; it never decodes them). The
  // stage's thread takes a few frames before the shut gate holds it: then nothing leaves the queue.
  uint64_t ok1 = 0, ok2 = 0;
  for (uint64_t seq = 1; seq <= 200; seq++) {
    assemble::PartialHull big = hull(1, seq);
    big.rle.resize(8192, 0);
    ok1 += a.post_hull(std::move(big)) ? 1 : 0;
    ok2 += a.post_hull(hull(2, seq)) ? 1 : 0;
  }
  EXPECT_LE(ok1, 12u) << "node 1 held to about 64 KiB";
  EXPECT_GE(ok1, 7u);
  EXPECT_EQ(ok2, 200u) << "node 2 was never crowded out";
  EXPECT_EQ(a.drops()[2], 0u);
  EXPECT_EQ(a.drops()[1], 200u - ok1);
  gate.release();
  a.stop();
  p.stop();
}

// Pulse notes are bounded too (issue #13): while the assembly thread is held back (a stage that does
// not take frames) and the nodes flood its queue, 100000 pulses never grow the queue past its
// capacity nor the notes past the assembler's ring, and when the thread goes on the newest pulse is
// known: the hulls of the last pulsed seq are taken (not refused as unpulsed) and their frame's
// deadline runs from the host's time of that pulse.
TEST(AssemblyStage, PulseNotesStayBoundedUnderAFloodAndTheNewestPulseIsNeverLost) {
  pipeline::Pipeline p(pipeline::StageContext{});
  Gate& gate = p.tap(std::make_unique<Gate>(), {1, pipeline::Overflow::Block});
  p.start();
  assemble::AssemblerOptions o = options();
  o.pulsed_only = true;
  AssemblyStage a(o, {8, 1}, p, [](log::Level, const std::string&) {});
  a.set_running(1, true);
  a.set_running(2, true);
  a.start();
  // Three frames hold the thread: one in the gate, one in its queue, one being pushed.
  for (uint64_t seq = 1; seq <= 3; seq++) {
    a.post_pulse(seq, vc::monotonic_ns());
    ASSERT_TRUE(a.post_hull(hull(1, seq)));
    ASSERT_TRUE(a.post_hull(hull(2, seq)));
  }
  for (int i = 0; i < 400 && a.report().queue.depth > 0; i++) std::this_thread::sleep_for(5ms);
  ASSERT_EQ(a.report().queue.depth, 0u) << "the thread took the three frames and waits on the gate";
  uint64_t refused = 0, t_last = 0;
  const uint64_t kPulses = 100000, t0 = vc::monotonic_ns();
  for (uint64_t seq = 4; seq <= kPulses; seq++) {
    t_last = t0 + seq;  // the host's time of each pulse, told apart from any node's stamp
    a.post_pulse(seq, t_last);
    if (seq % 100 == 0) refused += a.post_features(1, seq, vc::monotonic_ns(), vc_features{}) ? 0 : 1;
  }
  EXPECT_GT(refused, 900u) << "the queue was full: the flood was refused";
  EXPECT_LE(a.report().queue.max_depth, 8u) << "pulse notes took places in the queue";
  EXPECT_LE(a.pulse_notes_waiting(), a.pulse_ring_size());
  EXPECT_EQ(a.pulse_ring_size(), o.max_pending);
  // The thread took the first three before it was held; of the rest only the newest max_pending wait.
  EXPECT_EQ(a.pulse_notes_waiting(), o.max_pending);
  EXPECT_EQ(a.pulse_notes_overwritten(), kPulses - 3 - o.max_pending);
  gate.release();
  for (int i = 0; i < 400 && a.report().queue.depth > 0; i++) std::this_thread::sleep_for(5ms);
  // The newest pulse was kept: its hulls are taken and make a complete frame, timed from the pulse.
  assemble::PartialHull h1 = hull(1, kPulses), h2 = hull(2, kPulses);
  h1.t_trigger_ns = h2.t_trigger_ns = 5;  // a node's stamp is not what the deadline runs from
  ASSERT_TRUE(a.post_hull(std::move(h1)));
  ASSERT_TRUE(a.post_hull(std::move(h2)));
  a.stop();
  p.stop();
  EXPECT_EQ(a.stats().nodes.at(1).unpulsed, 0u);
  EXPECT_EQ(a.stats().nodes.at(2).unpulsed, 0u);
  ASSERT_FALSE(gate.seqs.empty());
  EXPECT_EQ(gate.seqs.back(), kPulses);
  EXPECT_EQ(gate.t_trigger.back(), t_last);
  EXPECT_EQ(a.stats().complete, 4u);
  EXPECT_EQ(a.pulse_notes_waiting(), 0u);
}

TEST(AssemblyStage, WaitsOnlyForRunningNodesAndFlushesPendingFramesAtStop) {
  pipeline::Pipeline p(pipeline::StageContext{});
  Gate& gate = p.tap(std::make_unique<Gate>(), {16, pipeline::Overflow::Block});
  gate.release();
  p.start();
  assemble::AssemblerOptions o = options();
  o.policy = assemble::MissingPolicy::Degraded;
  AssemblyStage a(o, {}, p, {});
  a.set_running(1, true);
  a.set_running(2, false);  // node 2 not running: frames do not wait for it
  a.start();
  ASSERT_TRUE(a.post_hull(hull(1, 5)));
  for (int i = 0; i < 200 && a.stats().degraded == 0; i++) std::this_thread::sleep_for(5ms);
  EXPECT_EQ(a.stats().degraded, 1u);
  a.set_running(2, true);
  ASSERT_TRUE(a.post_hull(hull(1, 6)));  // waits for node 2 now
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(a.pending(), 1u);
  a.stop();  // flushed: merged without node 2
  p.stop();
  EXPECT_EQ(gate.seqs, (std::vector<uint64_t>{5, 6}));
  EXPECT_EQ(a.stats().degraded, 2u);
}

}  // namespace
}  // namespace vc::aggregator
