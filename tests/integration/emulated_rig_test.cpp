// The emulated rig end to end: the host aggregator in this process, one voxcap-edge process per node
// with sim cameras and the udp trigger, all on 127.0.0.1 — and the faults a real rig meets.
//
// Frames are 160x120 on a 48^3 grid: the suite runs under ASan/UBSan on 2 cores, where 6 cameras
// rendered, subtracted and carved at 60 Hz must fit. The same code runs at 640x480 / 128^3 in
// `voxcap rig --emulated` and `voxcap bench host` (release build).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <variant>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/proto.h"
#include "voxcap/record/recorder.hpp"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/allocator_interface.h>
#define VC_TEST_ASAN 1
#endif
#endif

namespace vc::emulated {
namespace {

using Clock = std::chrono::steady_clock;

Options options() {
  Options o;
  o.nodes = 3;
  o.motion = "wave";
  o.width = 160;
  o.height = 120;
  o.grid = 48;
  o.rate_hz = 60;
  o.deadline_ms = 150;
  o.missing_policy = "degraded";
  o.truth_every = 3;
  o.edge_binary = VOXCAP_EDGE_BINARY;
  return o;
}

const aggregator::NodeReport& node(const aggregator::Report& r, int k) {
  return r.nodes.at(static_cast<size_t>(k));
}

TEST(EmulatedRig, ThreeNodesSixHundredFramesCompleteAndMatchTheTrueSilhouettes) {
  EmulatedRig rig(options());
  rig.start(60);
  rig.run_frames(600, 120);
  Result r = rig.stop();
  ASSERT_GE(r.report.frames, 600u) << "merged only " << r.report.frames;
  // Nothing lost by the host: every pulse of the run became a merged frame.
  EXPECT_EQ(r.report.frames, r.report.last_seq - r.report.first_seq + 1);
  EXPECT_EQ(r.report.dropped + r.report.evicted, 0u);
  // Every frame complete: each node's HULL for every seq, within the deadline.
  RecordProperty("complete", std::to_string(r.report.complete));
  EXPECT_EQ(r.report.complete, r.report.frames)
      << r.report.degraded << " degraded, " << r.report.dropped << " dropped";
  uint64_t missing = 0;
  for (int k = 0; k < 3; k++) missing += node(r.report, k).missing;
  EXPECT_EQ(missing >= r.report.degraded, true) << "every degraded frame names its missing node";
  // The merged hull equals the hull of the true silhouettes but where subtraction differs.
  ASSERT_GT(r.accuracy.frames, 50u);
  EXPECT_GE(r.accuracy.min_agree, 0.99);
  EXPECT_GE(r.accuracy.agree, 0.995);
  EXPECT_GE(r.accuracy.body_recall, 0.8);
  // The rate (fps) is a figure, not a pass/fail criterion: `voxcap bench host` (rig.fps).
}

// Whether this build's host loads rig.toml's [silhouettes] and so asks the edges for their masks in
// CONFIG (the wire change). Before it no edge sends SILHOUETTE; after it every scored frame must have
// its masks. Decided from the rig's own rig.toml with the key added.
bool host_asks_for_silhouettes(const std::filesystem::path& rig_toml) {
  std::ifstream f(rig_toml);
  std::stringstream ss;
  ss << f.rdbuf();
  std::string text = ss.str();
  if (text.find("[silhouettes]") == std::string::npos) text += "\n[silhouettes]\nevery = 3\n";
  try {
    return config::parse_rig_config(text, rig_toml).silhouettes.every > 0;
  } catch (const config::ConfigError& e) {
    if (std::string(e.what()).find("unknown key") != std::string::npos) return false;
    throw;
  }
}

TEST(EmulatedRig, PartGroupsCoverEveryBodyPartOnce) {
  std::vector<int> parts_per_group(kPartGroups, 0);
  for (int p = 0; p < 20; p++) {
    const int g = part_group(p);
    ASSERT_GE(g, 0);
    ASSERT_LT(g, kPartGroups);
    parts_per_group[static_cast<size_t>(g)]++;
  }
  EXPECT_EQ(parts_per_group[0], 2);   // head + neck
  EXPECT_EQ(parts_per_group[1], 4);   // pelvis, abdomen, chest, shoulder girdle
  EXPECT_EQ(parts_per_group[12], 2);  // left foot + toes
  EXPECT_EQ(parts_per_group[13], 2);
  EXPECT_EQ(part_group_names()[6], "l_hand");
  EXPECT_THROW(part_group(20), std::out_of_range);
  Options o = options();
  o.room = "cave";
  std::string why;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_NE(why.find("unknown room 'cave'"), std::string::npos) << why;
  o = options();
  o.appearance = "purple";
  EXPECT_FALSE(o.valid(&why));
  o = options();
  o.carve = "corner";
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THROW(EmulatedRig{o}, std::invalid_argument);
}

// One cell of the accuracy sweep (tests/bench/rig_accuracy.cmake runs them all): wave, 3 nodes, the
// default appearance and room. Every figure is present and sane, and the edges' masks are scored on
// every scored frame once the host asks for them, or all counted missing before.
TEST(EmulatedRig, SweepCellReportsPerPartHullAndSilhouetteFigures) {
  Options o = options();
  o.workdir = std::filesystem::path(::testing::TempDir()) / "vc_rig_sweep_cell";
  std::filesystem::remove_all(o.workdir);
  EmulatedRig rig(o);
  rig.start(60);
  rig.run_frames(300, 90);
  Result r = rig.stop();
  const Accuracy& a = r.accuracy;
  ASSERT_GT(a.frames, 50u);
  auto in01 = [](double v) { return v >= 0 && v <= 1; };
  EXPECT_TRUE(in01(a.body_recall));
  EXPECT_GT(a.body_recall, 0.5);
  EXPECT_TRUE(in01(a.hull_precision));
  EXPECT_GT(a.hull_precision, 0.8);
  EXPECT_EQ(a.hull_precision_frames, a.frames);
  EXPECT_FALSE(a.reference_carve.empty());
  for (size_t g = 0; g < kPartGroups; g++) {
    EXPECT_TRUE(in01(a.part_recall[g])) << part_group_names()[g];
    EXPECT_GT(a.part_frames[g], 0u) << part_group_names()[g];
    EXPECT_LE(a.part_frames[g], a.frames) << part_group_names()[g];
  }
  // Head and torso are always in the grid and mostly kept.
  EXPECT_EQ(a.part_frames[0], a.frames);
  EXPECT_EQ(a.part_frames[1], a.frames);
  EXPECT_GT(a.part_recall[1], 0.8);
  // Every scored frame accounts for every camera's mask: scored, missing or bad.
  ASSERT_EQ(a.cameras.size(), 6u);
  for (const SilhouetteScore& c : a.cameras) EXPECT_EQ(c.frames + c.missing + c.bad, a.frames);
  EXPECT_EQ(a.silhouettes.frames + a.silhouettes.missing + a.silhouettes.bad, 6 * a.frames);
  if (host_asks_for_silhouettes(o.workdir / "rig.toml")) {
    // The edges send their masks for the frames whose seq is a multiple of truth_every: all of
    // them, each the mask the edge carved with.
    EXPECT_EQ(a.silhouettes.bad, 0u);
    // A mask can miss a frame the way a hull can (a node late for a degraded frame, or its silhouette
    // not queued because the send queue was half full: counted on the edge); under the sanitizers on 2
    // loaded cores that is a few frames, never most of them.
    EXPECT_LE(a.silhouettes.missing * 10, 6 * a.frames) << "the host asks for masks but many never came";
    ASSERT_GT(a.silhouettes.frames, 0u) << "the host asks for masks but no edge sent one";
    for (const SilhouetteScore& c : a.cameras) {
      EXPECT_GT(c.recall, 0.5);
      EXPECT_LE(c.recall, 1.0);
      EXPECT_GT(c.precision, 0.5);
      EXPECT_LE(c.precision, 1.0);
      EXPECT_TRUE(in01(c.shadow_kept));
    }
  } else {
    // No edge sends masks yet: counted missing, never scored as perfect.
    EXPECT_EQ(a.silhouettes.frames, 0u);
    EXPECT_EQ(a.silhouettes.missing, 6 * a.frames);
    EXPECT_EQ(a.silhouettes.recall, 0.0);
  }
}

TEST(EmulatedRig, KilledEdgeIsMissedAndItsRestartRejoins) {
  EmulatedRig rig(options());
  rig.start(60);
  rig.run_frames(60, 30);
  rig.kill_node(1, SIGKILL);
  uint64_t before = rig.merged_frames();
  rig.run_seconds(1.0);
  aggregator::Report during = rig.report();
  EXPECT_GT(rig.merged_frames(), before + 20) << "the host must go on without the node";
  EXPECT_GT(during.degraded, 0u) << "frames without node 1 are marked degraded";
  EXPECT_FALSE(node(during, 1).connected);

  auto t0 = Clock::now();
  rig.restart_node(1);
  while (!rig.node_running(1) && Clock::now() - t0 < std::chrono::seconds(10))
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  double rejoin_s = std::chrono::duration<double>(Clock::now() - t0).count();
  ASSERT_TRUE(rig.node_running(1));
  // How fast is a figure (`voxcap bench host`: rig.rejoin_ms), not a pass/fail criterion.
  RecordProperty("rejoin_ms", std::to_string(int(rejoin_s * 1000)));
  uint64_t complete_before = rig.report().complete;
  rig.run_seconds(1.0);
  Result r = rig.stop();
  EXPECT_GT(r.report.complete, complete_before + 20) << "complete frames again after the rejoin";
  EXPECT_EQ(node(r.report, 1).joins, 2u);
}

int connect_host(uint16_t port) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  return fd;
}

bool closed_within(int fd, int ms) {
  auto end = Clock::now() + std::chrono::milliseconds(ms);
  char b[512];
  while (Clock::now() < end) {
    timeval tv{0, 20000};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    ssize_t n = recv(fd, b, sizeof(b), 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) return true;
  }
  return false;
}

TEST(EmulatedRig, GarbageAndTruncatedMessagesDropOnlyThatConnection) {
  EmulatedRig rig(options());
  rig.start(60);
  rig.run_frames(30, 30);

  // A connection sending garbage.
  int junk = connect_host(rig.host_port());
  const char text[] = "GET / HTTP/1.1\r\nHost: voxcap\r\n\r\n";
  ASSERT_GT(send(junk, text, sizeof(text), MSG_NOSIGNAL), 0);
  EXPECT_TRUE(closed_within(junk, 3000));
  close(junk);

  // A connection that says HELLO for a rig node and then sends half a HULL and hangs up.
  int cut = connect_host(rig.host_port());
  uint8_t buf[512];
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = 9;  // not a rig node: the HELLO is rejected, the connection dropped
  vc_hello h{};
  h.node_id = 9;
  h.camera_count = 2;
  for (int c = 0; c < 2; c++) {
    h.cameras[c].width = 160;
    h.cameras[c].height = 120;
  }
  ASSERT_EQ(vc_encode_hello(buf, sizeof(buf), &len, &hdr, &h), 0);
  ASSERT_EQ(send(cut, buf, len, MSG_NOSIGNAL), (ssize_t)len);
  EXPECT_TRUE(closed_within(cut, 3000));
  close(cut);

  int trunc = connect_host(rig.host_port());
  std::vector<uint8_t> bits(6 * 6 * 6 / 8 + 1, 0x0F);
  std::vector<uint8_t> hull(1024);
  hdr.node_id = 0;
  ASSERT_EQ(vc_encode_hull_bits(hull.data(), hull.size(), &len, &hdr, 1, bits.data(), 6 * 6 * 6), 0);
  ASSERT_EQ(send(trunc, hull.data(), len / 2, MSG_NOSIGNAL), (ssize_t)(len / 2));
  close(trunc);  // EOF inside the message

  uint64_t complete_before = rig.report().complete;
  rig.run_seconds(1.0);
  Result r = rig.stop();
  EXPECT_GE(r.report.server.decode_drops, 1u) << "the garbage connection was dropped for its bytes";
  EXPECT_GE(r.report.server.hello_rejected, 1u) << "the unknown node never got past HELLO";
  EXPECT_GT(r.report.complete, complete_before + 30) << "the real nodes went on";
  for (int k = 0; k < 3; k++) EXPECT_EQ(node(r.report, k).joins, 1u) << "node " << k << " was not disturbed";
}

// Resident memory of this process in kB, after AddressSanitizer (ci preset) hands back the freed
// blocks it keeps in quarantine to catch use-after-free: without that, RSS follows how much the host
// allocated and freed (up to 256 MB of quarantine), not how much it holds.
long live_rss_kb() {
#ifdef VC_TEST_ASAN
  __sanitizer_purge_allocator();
#endif
  return emulated::rss_kb();
}

TEST(EmulatedRig, StalledNodeIsCountedLateAndMemoryStaysFlat) {
  Options o = options();
  o.truth_every = 0;
  EmulatedRig rig(o);
  rig.start(60);
  rig.run_frames(60, 30);
  long rss_before = live_rss_kb();
  rig.signal_node(2, SIGSTOP);  // the process freezes: no hulls, no heartbeats
  rig.run_seconds(1.0);
  aggregator::Report stalled = rig.report();
  EXPECT_LE(stalled.pending_frames, 64u) << "bounded, whatever the node does";
  rig.signal_node(2, SIGCONT);  // it wakes up with a backlog
  rig.run_seconds(1.5);
  long rss_after = live_rss_kb();
  Result r = rig.stop();
  EXPECT_GT(node(r.report, 2).missing, 30u) << "frames resolved without the stalled node";
  EXPECT_GT(node(r.report, 2).late + node(r.report, 2).edge_queue_drops +
                node(r.report, 2).edge_pulses_without_frame,
            0u)
      << "its backlog is counted, not merged";
  EXPECT_GT(r.report.degraded, 30u);
  EXPECT_LT(rss_after - rss_before, 16 * 1024) << "host memory grew by " << (rss_after - rss_before) << " kB";
}

// A stage that sleeps `seconds` in process() on the `at`-th frame it sees, as a slow viewer or a disk
// that stops for a while would.
class Stall : public pipeline::Stage {
 public:
  Stall(std::string name, uint64_t at, double seconds) : name_(std::move(name)), at_(at), seconds_(seconds) {}
  std::string name() const override { return name_; }
  void process(pipeline::Frame&) override {
    if (++seen_ == at_) {
      stalled_ = true;
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds_));
      stalled_ = false;
      done_ = true;
    }
  }
  bool stalling() const { return stalled_; }
  bool done() const { return done_; }

 private:
  std::string name_;
  uint64_t at_;
  double seconds_;
  std::atomic<uint64_t> seen_{0};
  std::atomic<bool> stalled_{false}, done_{false};
};

TEST(EmulatedRig, AStalledStageDropsNoNodeAndItsFramesAreAccounted) {
  namespace fs = std::filesystem;
  char tmp[] = "/tmp/voxcap-stall-XXXXXX";
  ASSERT_NE(mkdtemp(tmp), nullptr);
  Options o = options();
  o.truth_every = 0;
  o.record_dir = tmp;
  Stall *live = nullptr, *must_see = nullptr;
  // Both stall for 3 s — longer than the session's heartbeat timeout (2 s) — at the same frame: a live
  // consumer (drops the oldest) and one that must see every frame (blocks the merge stage behind it).
  o.stages = [&](pipeline::Pipeline& p) {
    live = &p.tap(std::make_unique<Stall>("stalled-live", 30, 3.0), {4, pipeline::Overflow::DropOldest});
    must_see = &p.tap(std::make_unique<Stall>("stalled-block", 30, 3.0), {512, pipeline::Overflow::Block});
  };
  EmulatedRig rig(o);
  rig.start(60);
  auto end = Clock::now() + std::chrono::seconds(30);
  while (!must_see->stalling() && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(must_see->stalling());
  uint64_t at_stall = rig.merged_frames();
  rig.run_seconds(1.5);
  aggregator::Report during = rig.report();
  EXPECT_TRUE(must_see->stalling()) << "still asleep";
  EXPECT_GT(during.pipeline.stage("stalled-block")->queue.depth, 20u) << "its frames wait for it";
  EXPECT_GT(rig.merged_frames(), at_stall + 20) << "the other stages go on";
  while (!(must_see->done() && live->done()) && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  rig.run_seconds(1.0);
  aggregator::Report after = rig.report();
  Result r = rig.stop();

  for (int k = 0; k < 3; k++) {
    SCOPED_TRACE(k);
    EXPECT_TRUE(node(after, k).connected) << "connected throughout";
    EXPECT_EQ(node(r.report, k).joins, 1u);
    EXPECT_EQ(node(r.report, k).leaves, 0u) << "no node left during the stall";
    EXPECT_EQ(node(r.report, k).host_queue_drops, 0u) << "the assembly stage's queue never overflowed";
  }
  EXPECT_EQ(r.report.server.timeouts, 0u) << "no heartbeat timeout";
  EXPECT_EQ(r.report.dropped + r.report.evicted, 0u);
  EXPECT_GT(r.report.frames, 250u);

  // Once everything drained at stop: every frame that left the chain (counted by `figures`) reached
  // each consumer — processed or, for the live one only, dropped.
  const pipeline::StageReport* fig = r.stages.stage("figures");
  const pipeline::StageReport* lr = r.stages.stage("stalled-live");
  const pipeline::StageReport* br = r.stages.stage("stalled-block");
  const pipeline::StageReport* rec = r.stages.stage("record");
  ASSERT_TRUE(fig && lr && br && rec);
  const uint64_t frames = fig->processed;
  EXPECT_GE(frames, r.report.frames);
  EXPECT_GT(lr->queue.dropped, 100u) << "the live consumer skipped the stall's frames";
  EXPECT_EQ(lr->processed + lr->queue.dropped, frames) << "every frame accounted: shown or dropped";
  EXPECT_EQ(br->queue.dropped, 0u);
  EXPECT_EQ(br->processed, frames) << "delayed, but every frame";
  EXPECT_GT(br->queue.max_depth, 100u);
  EXPECT_GE(br->busy_ms_max, 2900.0);
  EXPECT_EQ(rec->processed, frames);
  EXPECT_EQ(rec->queue.dropped, 0u);
  for (const auto& s : r.stages.stages) EXPECT_EQ(s.errors, 0u) << s.name;

  // The recording has every frame; during the run (the stall included) no seq is missing.
  ASSERT_FALSE(r.session_dir.empty());
  record::Reader reader = record::Reader::open(r.session_dir);
  EXPECT_TRUE(reader.summary().closed_cleanly);
  EXPECT_EQ(reader.summary().frames, frames);
  std::set<uint64_t> seqs;
  record::Record rr;
  while (reader.next(rr))
    if (auto* f = std::get_if<record::FrameRecord>(&rr)) seqs.insert(f->seq);
  uint64_t in_run = 0;
  for (uint64_t q = r.report.first_seq; q <= r.report.last_seq; q++) in_run += seqs.count(q);
  EXPECT_EQ(in_run, r.report.last_seq - r.report.first_seq + 1) << "a gap in the recording";
  fs::remove_all(tmp);
}

// Tracking on every node (the default, [tracking] nodes = "all"): each node sends one FEATURES per
// camera for every frame, all five features in each, lost or unseen ones included; the front pair,
// which sees the init pose face on, tracks the head in nearly every frame after initialization.
TEST(EmulatedRig, EveryNodeSendsFeaturesForEveryCameraEveryFrame) {
  namespace fs = std::filesystem;
  char tmp[] = "/tmp/voxcap-track-XXXXXX";
  ASSERT_NE(mkdtemp(tmp), nullptr);
  Options o = options();
  o.width = 320;  // the hands are a few pixels at 160x120: too small to tell from noise
  o.height = 240;
  o.rate_hz = 30;
  o.truth_every = 0;
  o.record_dir = tmp;
  EmulatedRig rig(o);
  rig.start(30);
  rig.run_frames(240, 120);
  Result r = rig.stop();
  ASSERT_GE(r.report.frames, 240u);
  for (int k = 0; k < 3; k++) {
    SCOPED_TRACE(k);
    // Two FEATURES for every HULL, joined or late alike (under the sanitizers on 2 cores a frame's
    // deadline can pass while a node's messages are on their way, as it can for its HULL).
    const aggregator::NodeReport& n = node(r.report, k);
    // (A few of the run's first and last frames may lose theirs at the host's start and stop: up to 8
    // frames' worth measured on the loaded 2-core machine.)
    EXPECT_GE(n.features + n.features_late + 16, 2 * (n.hulls + n.late)) << "two FEATURES with every HULL";
    EXPECT_LE(n.features + n.features_late, 2 * (n.hulls + n.late)) << "and never more";
    EXPECT_GE(n.features, 2 * r.report.frames * 9 / 10) << "nearly all of them joined their frame";
  }
  record::Reader reader = record::Reader::open(r.session_dir);
  std::map<std::pair<uint64_t, int>, int> per_frame_node;  // (seq, node) -> FEATURES records
  int front_head = 0, front_head_tracking = 0;
  record::Record rr;
  while (reader.next(rr)) {
    const auto* f = std::get_if<record::FeatureRecord>(&rr);
    if (!f) continue;
    per_frame_node[{f->seq, f->node_id}]++;
    ASSERT_EQ(f->features.size(), 5u);
    for (size_t i = 0; i < 5; i++) {
      EXPECT_EQ(f->features[i].id, i);
      EXPECT_LT(f->features[i].state, VC_FEATURE_STATE_COUNT);
      EXPECT_TRUE(f->features[i].confidence >= 0 && f->features[i].confidence <= 1);
    }
    if (f->node_id == 0 && f->seq >= r.report.first_seq + 30) {  // past the init frames
      front_head++;
      front_head_tracking += f->features[0].state == VC_FEATURE_TRACKING;
    }
  }
  size_t both = 0;
  for (const auto& [key, n] : per_frame_node) {
    EXPECT_LE(n, 2) << "seq " << key.first << " node " << key.second;  // one per camera, never more
    both += n == 2;
  }
  EXPECT_GE(both, 3 * r.report.frames * 9 / 10) << "both cameras' FEATURES in the recorded frame";
  ASSERT_GT(front_head, 300);
  EXPECT_GE(front_head_tracking, front_head * 9 / 10) << "the front pair tracks the head";
  fs::remove_all(tmp);
}

}  // namespace
}  // namespace vc::emulated
