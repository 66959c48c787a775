// The aggregator's session state machine against fake edges on 127.0.0.1 (no trigger: pulses are
// noted by the test). Loops are bounded in time.
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/aggregator/record_stage.hpp"
#include "voxcap/auth.h"
#include "voxcap/base/clock.hpp"
#include "voxcap/record/pose.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "voxcap/rig/calibration.hpp"
#include "voxcap/rle.h"

namespace vc::aggregator {
namespace {

namespace fs = std::filesystem;

struct TmpDir {
  fs::path p;
  TmpDir() {
    char t[] = "/tmp/voxcap-agg-XXXXXX";
    p = mkdtemp(t);
  }
  ~TmpDir() { fs::remove_all(p); }
};

// A port nobody listens on right now (the config wants a fixed port; tests run in parallel).
int free_port() {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0)
    ADD_FAILURE() << "bind: " << std::strerror(errno);
  socklen_t len = sizeof(a);
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  close(fd);
  return ntohs(a.sin_port);
}

config::RigConfig make_rig(const fs::path& dir) {
  rig::Calibration cal;
  for (int k = 0; k < 4; k++) {
    rig::Camera c;
    c.name = "cam" + std::to_string(k);
    c.width = 64;
    c.height = 48;
    c.K = cv::Matx33d(60, 0, 32, 0, 60, 24, 0, 0, 1);
    c.t_cam_from_world = cv::Vec3d(0, 0, 3);
    cal.cameras.push_back(c);
  }
  rig::write_calibration((dir / "cal.yaml").string(), cal);
  std::string toml = R"(
version = 1
name = "test"
calibration = "cal.yaml"
[grid]
min_m = [-0.5, -0.5, 0.0]
voxel_m = 0.25
nx = 4
ny = 4
nz = 4
[[nodes]]
id = "node1"
cameras = ["cam0", "cam1"]
role = "front"
[[nodes]]
id = "node2"
cameras = ["cam2", "cam3"]
[trigger]
backend = "udp"
rate_hz = 60
[trigger.udp]
targets = ["127.0.0.1:7801", "127.0.0.1:7802"]
[assembly]
deadline_ms = 500
missing_node_policy = "degraded"
[network]
listen = "127.0.0.1"
port = )" + std::to_string(free_port()) +
                     "\n";
  std::ofstream(dir / "rig.toml") << toml;
  return config::load_rig_config(dir / "rig.toml");
}

vc_decoder* new_decoder() {
  vc_decoder* dec = nullptr;
  char why[128];
  EXPECT_EQ(vc_decoder_new(0, &dec, why, sizeof why), 0) << why;
  return dec;
}

struct FakeEdge {
  int fd = -1;
  uint16_t id;
  vc_decoder* dec = new_decoder();
  FakeEdge(uint16_t port, uint16_t node, int w = 64) : id(node) {
    fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    vc_hello h{};
    h.node_id = node;
    h.camera_count = 2;
    for (int c = 0; c < 2; c++) {
      h.cameras[c].width = static_cast<uint16_t>(w);
      h.cameras[c].height = 48;
    }
    uint8_t buf[256];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = node;
    EXPECT_EQ(vc_encode_hello(buf, sizeof(buf), &len, &hdr, &h), 0);
    write_all(buf, len);
  }
  ~FakeEdge() {
    vc_decoder_free(dec);
    close(fd);
  }
  void write_all(const uint8_t* b, size_t n) { ASSERT_EQ(send(fd, b, n, MSG_NOSIGNAL), (ssize_t)n); }
  void state(uint32_t s) {
    uint8_t buf[128];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    vc_heartbeat hb{1, s};
    ASSERT_EQ(vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &hb), 0);
    write_all(buf, len);
  }
  void hull(uint64_t seq, uint64_t t, uint32_t grid, const std::vector<uint8_t>& bits) {
    std::vector<uint8_t> buf(1024);
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    hdr.seq = seq;
    hdr.t_trigger_ns = t;
    ASSERT_EQ(vc_encode_hull_bits(buf.data(), buf.size(), &len, &hdr, grid, bits.data(), 64), 0);
    write_all(buf.data(), len);
  }
  void features(uint64_t seq, uint64_t t, uint16_t camera) {
    uint8_t buf[1024];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    hdr.seq = seq;
    hdr.t_trigger_ns = t;
    vc_features f{};
    f.camera = camera;
    f.feature_count = 1;
    f.features[0].feature_id = 1;
    f.features[0].u = 10.5f;
    f.features[0].v = 20.5f;
    f.features[0].confidence = 0.9f;
    ASSERT_EQ(vc_encode_features(buf, sizeof(buf), &len, &hdr, &f), 0);
    write_all(buf, len);
  }
  void stats() {
    uint8_t buf[2048];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    vc_stats s{};
    s.frames = 60;
    s.stage_count = 1;
    s.stages[0].stage_id = VC_STAGE_FRAME;
    s.stages[0].mean_ns = 2'000'000;
    s.stages[0].max_ns = 3'000'000;
    ASSERT_EQ(vc_encode_stats(buf, sizeof(buf), &len, &hdr, &s), 0);
    write_all(buf, len);
  }
  // A FRAME (2.4) of a w x 48 image whose bytes are (seq + i) mod 251.
  void frame(uint64_t seq, uint64_t t, uint16_t camera, uint16_t format, int w = 64) {
    const size_t n = size_t(w) * 48 * vc_frame_format_channels(format);
    std::vector<uint8_t> px(n), buf(VC_PROTO_HEADER_SIZE + 16 + n);
    for (size_t i = 0; i < n; i++) px[i] = static_cast<uint8_t>((seq + i) % 251);
    vc_frame_msg f{camera, format, static_cast<uint16_t>(w), 48, static_cast<uint32_t>(n), px.data()};
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    hdr.seq = seq;
    hdr.t_trigger_ns = t;
    ASSERT_EQ(vc_encode_frame(buf.data(), buf.size(), &len, &hdr, &f), 0);
    write_all(buf.data(), len);
  }
  vc_grab last_grab{};  // the body of the last GRAB expect() returned
  // Waits for a message of `type`; returns its header seq, or -1.
  int64_t expect(uint16_t type, int ms = 3000) {
    auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    uint8_t b[8192];
    while (std::chrono::steady_clock::now() < end) {
      vc_msg m;
      while (vc_decoder_next(dec, &m) > 0)
        if (m.hdr.type == type) {
          if (type == VC_MSG_GRAB) last_grab = m.u.grab;
          return (int64_t)m.hdr.seq;
        }
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      ssize_t n = recv(fd, b, sizeof(b), 0);
      if (n <= 0) return -2;
      size_t used = 0;
      for (size_t off = 0; off < (size_t)n; off += used) vc_decoder_feed(dec, b + off, n - off, &used);
    }
    return -1;
  }
};

// A consumer stage that keeps every frame.
struct FrameSink : pipeline::Stage {
  std::mutex mu;
  std::vector<assemble::MergedFrame> frames;
  std::string name() const override { return "test-sink"; }
  void process(pipeline::Frame& f) override {
    std::lock_guard<std::mutex> g(mu);
    frames.push_back(f);
  }
};

TEST(Latency, PercentilesComeFromAUniformSampleOfTheWholeRunInBoundedMemory) {
  Latency l;
  const uint64_t n = 200000;
  for (uint64_t v = 0; v < n; v++) l.add(v * 1000);  // rising: a window of recent values would say ~199000
  EXPECT_EQ(l.n, n);
  EXPECT_EQ(l.samples.size(), Latency::kReservoir);
  EXPECT_EQ(l.samples.capacity(), Latency::kReservoir);
  EXPECT_NEAR(l.mean_ms(), (n - 1) / 2.0 / 1000.0, 1e-6);
  EXPECT_NEAR(l.percentile_ms(0.5), 100.0, 100.0 * 0.05);   // true median: 100 ms
  EXPECT_NEAR(l.percentile_ms(0.99), 198.0, 198.0 * 0.01);  // true p99: 198 ms
  Latency few;
  for (uint64_t v : {3000000ull, 1000000ull, 2000000ull}) few.add(v);
  EXPECT_DOUBLE_EQ(few.percentile_ms(0.5), 2.0);
  EXPECT_DOUBLE_EQ(few.percentile_ms(1.0), 3.0);
  EXPECT_DOUBLE_EQ(Latency{}.percentile_ms(0.5), 0.0);
}

// "voxcap rig prints fps: 60.0 and exits 0" after the frames stopped merging: the report tells.
TEST(Report, MergingStoppedWhenMoreThanASecondOfPulsesNeverMerged) {
  Report r;
  r.rate_hz = 60;
  r.origin = 100;
  r.last_pulse = 400;
  EXPECT_FALSE(r.merging_stopped()) << "not started";
  r.running = true;
  EXPECT_TRUE(r.merging_stopped()) << "started, nothing merged: 301 pulses since the origin";
  EXPECT_EQ(r.unmerged_pulses(), 301u);
  r.frames = 200;
  r.first_seq = 100;
  r.last_seq = 299;
  EXPECT_TRUE(r.merging_stopped());
  EXPECT_EQ(r.unmerged_pulses(), 101u);
  r.last_seq = 340;  // 60 pulses: within a second (and below 64)
  EXPECT_FALSE(r.merging_stopped());
  r.last_seq = 336;
  EXPECT_FALSE(r.merging_stopped()) << "64 is the floor";
  r.last_seq = 335;
  EXPECT_TRUE(r.merging_stopped());
  r.rate_hz = 240;  // a second is 240 pulses here
  EXPECT_FALSE(r.merging_stopped());
  // A frame may wait for its hulls until its deadline: a second past it. A deadline of a second at
  // 60 Hz lets 120 pulses wait (60 of them rightly, for a slow node), not 64.
  r.rate_hz = 60;
  r.deadline_ms = 1000;
  r.last_seq = 280;
  EXPECT_FALSE(r.merging_stopped()) << "120 pulses";
  r.last_seq = 279;
  EXPECT_TRUE(r.merging_stopped()) << "121 pulses";
}

TEST(Aggregator, ConfigMessageCarriesTheCalibrationOfTheNodesCameras) {
  TmpDir tmp;
  config::RigConfig rig = make_rig(tmp.p);
  vc_config c = make_config_message(rig, rig.nodes[1], 42);
  EXPECT_EQ(c.grid_id, 42u);
  EXPECT_EQ(c.camera_count, 2);
  EXPECT_EQ(c.grid.nx, 4u);
  EXPECT_DOUBLE_EQ(c.grid.voxel_m, 0.25);
  EXPECT_EQ(c.cameras[0].width, 64u);
  EXPECT_DOUBLE_EQ(c.cameras[1].K[0], 60.0);
  EXPECT_DOUBLE_EQ(c.cameras[1].t_cam_from_world[2], 3.0);
  EXPECT_NE(grid_id(rig.grid), 0u);
}

TEST(Aggregator, ConfigMessageCarriesCarvingAndSilhouettesToA21NodeOnly) {
  TmpDir tmp;
  config::RigConfig rig = make_rig(tmp.p);
  vc_config c = make_config_message(rig, rig.nodes[0], 42);  // the rig's defaults
  EXPECT_EQ(c.carve_rule, VC_CARVE_SUBPIXEL);
  c = make_config_message(rig, rig.nodes[0], 42, 1);  // a 2.1 node knows no subpixel: footprint holds it
  EXPECT_EQ(c.carve_rule, VC_CARVE_FOOTPRINT);
  c = make_config_message(rig, rig.nodes[0], 42, 2);
  EXPECT_EQ(c.carve_rule, VC_CARVE_SUBPIXEL);
  EXPECT_EQ(c.silhouette_every, 0);
  EXPECT_EQ(c.silhouette_scale, 1);
  rig.carving.rule = config::CarveRule::Centre;
  rig.silhouettes.every = 3;
  rig.silhouettes.scale = 4;
  c = make_config_message(rig, rig.nodes[0], 42, 1);
  EXPECT_EQ(c.carve_rule, VC_CARVE_CENTRE);
  EXPECT_EQ(c.silhouette_every, 3);
  EXPECT_EQ(c.silhouette_scale, 4);
  rig.carving.rule = config::CarveRule::Footprint;
  c = make_config_message(rig, rig.nodes[0], 42, 0);  // a 2.0 node: its `reserved` stays 0
  EXPECT_EQ(c.carve_rule, 0);
  EXPECT_EQ(c.silhouette_every, 0);
  EXPECT_EQ(c.silhouette_scale, 0);
  std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 4096);
  size_t len = 0;
  vc_header hdr{};
  EXPECT_EQ(vc_encode_config(buf.data(), buf.size(), &len, &hdr, &c), 0);  // and a 2.1 encoder takes it
}

TEST(Aggregator, DrivesNodesThroughTheSessionAndMergesTheirHulls) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  Aggregator agg(make_rig(tmp.p), o);
  FrameSink& sink = agg.pipeline().tap(std::make_unique<FrameSink>(), {64, pipeline::Overflow::Block});
  agg.start();
  agg.note_pulse(100, 0);

  FakeEdge e1(agg.port(), 1), e2(agg.port(), 2);
  ASSERT_EQ(e1.expect(VC_MSG_CONFIG), 0);
  ASSERT_EQ(e2.expect(VC_MSG_CONFIG), 0);
  e1.state(VC_STATE_CONFIGURED);
  e2.state(VC_STATE_CONFIGURED);
  ASSERT_GE(e1.expect(VC_MSG_BACKGROUND), 0);
  ASSERT_GE(e2.expect(VC_MSG_BACKGROUND), 0);
  e1.state(VC_STATE_READY);
  EXPECT_EQ(e1.expect(VC_MSG_START, 300), -1);  // not before every node is ready
  e2.state(VC_STATE_READY);
  int64_t origin = e2.expect(VC_MSG_START);
  ASSERT_EQ(e1.expect(VC_MSG_START), origin);
  EXPECT_EQ(origin, 118);  // last pulse + the margin (0.3 s at 60 Hz)
  e1.state(VC_STATE_RUNNING);
  e2.state(VC_STATE_RUNNING);
  for (int i = 0; i < 100 && !agg.all_running(); i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(agg.all_running());

  uint32_t gid = grid_id(make_rig(tmp.p).grid);
  std::vector<uint8_t> a(8, 0xF0), b(8, 0x3C);
  uint64_t t106 = vc::monotonic_ns();
  agg.note_pulse(118, t106);  // a hull is taken only for a seq the host has pulsed
  e1.hull(118, t106, gid, a);
  e2.hull(118, t106, gid, b);
  for (int i = 0; i < 200; i++) {
    {
      std::lock_guard<std::mutex> g(sink.mu);
      if (!sink.frames.empty()) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  {
    std::lock_guard<std::mutex> g(sink.mu);
    ASSERT_EQ(sink.frames.size(), 1u);
    EXPECT_EQ(sink.frames[0].seq, 118u);
    EXPECT_EQ(sink.frames[0].occupied, 8u * 2);  // 0xF0 & 0x3C = 0x30: two bits a byte
    EXPECT_FALSE(sink.frames[0].degraded);
  }

  // Node 2 leaves: the next frame is merged without it (degraded) at the deadline.
  close(e2.fd);
  e2.fd = socket(AF_INET, SOCK_STREAM, 0);
  for (int i = 0; i < 200 && agg.report().nodes[1].connected; i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  agg.note_pulse(119, vc::monotonic_ns());
  e1.hull(119, vc::monotonic_ns(), gid, a);
  for (int i = 0; i < 400; i++) {
    {
      std::lock_guard<std::mutex> g(sink.mu);
      if (sink.frames.size() == 2) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  {
    std::lock_guard<std::mutex> g(sink.mu);
    ASSERT_EQ(sink.frames.size(), 2u);
    EXPECT_TRUE(sink.frames[1].degraded);
    EXPECT_EQ(sink.frames[1].missing, std::vector<uint16_t>{2});
  }
  // It rejoins: CONFIG again, and the same origin once it is ready.
  FakeEdge e2b(agg.port(), 2);
  ASSERT_EQ(e2b.expect(VC_MSG_CONFIG), 0);
  e2b.state(VC_STATE_CONFIGURED);
  ASSERT_GE(e2b.expect(VC_MSG_BACKGROUND), 0);
  e2b.state(VC_STATE_READY);
  EXPECT_EQ(e2b.expect(VC_MSG_START), origin);
  Report r = agg.report();
  EXPECT_EQ(r.nodes[1].joins, 2u);
  EXPECT_EQ(r.nodes[1].leaves, 1u);
  agg.stop();
}

// Both fake edges through HELLO .. RUNNING; returns the run's origin seq.
int64_t bring_up(Aggregator& agg, FakeEdge& e1, FakeEdge& e2) {
  agg.note_pulse(100, 0);
  EXPECT_EQ(e1.expect(VC_MSG_CONFIG), 0);
  EXPECT_EQ(e2.expect(VC_MSG_CONFIG), 0);
  e1.state(VC_STATE_CONFIGURED);
  e2.state(VC_STATE_CONFIGURED);
  EXPECT_GE(e1.expect(VC_MSG_BACKGROUND), 0);
  EXPECT_GE(e2.expect(VC_MSG_BACKGROUND), 0);
  e1.state(VC_STATE_READY);
  e2.state(VC_STATE_READY);
  int64_t origin = e1.expect(VC_MSG_START);
  EXPECT_EQ(e2.expect(VC_MSG_START), origin);
  e1.state(VC_STATE_RUNNING);
  e2.state(VC_STATE_RUNNING);
  for (int i = 0; i < 200 && !agg.all_running(); i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(agg.all_running());
  return origin;
}

TEST(Aggregator, FeaturesAndStatsTravelWithTheirFrameThroughEveryStageIntoTheRecording) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  config::RigConfig rig = make_rig(tmp.p);
  uint32_t gid = grid_id(rig.grid);
  Aggregator agg(rig, o);
  FrameSink& sink = agg.pipeline().tap(std::make_unique<FrameSink>(), {64, pipeline::Overflow::Block});
  RecordStage& rec = agg.pipeline().tap(std::make_unique<RecordStage>(tmp.p / "rec"), RecordStage::kQueue);
  agg.start();
  ASSERT_TRUE(fs::is_directory(rec.dir())) << "the session folder exists once started";
  FakeEdge e1(agg.port(), 1), e2(agg.port(), 2);
  int64_t origin = bring_up(agg, e1, e2);
  ASSERT_GT(origin, 0);
  uint64_t seq = static_cast<uint64_t>(origin), t = vc::monotonic_ns();
  agg.note_pulse(seq, t);
  std::vector<uint8_t> a(8, 0xF0), b(8, 0x3C);
  e1.stats();
  e1.features(seq, t, 0);  // the front node's features, before and after its hull
  e1.hull(seq, t, gid, a);
  e1.features(seq, t, 1);
  e2.hull(seq, t, gid, b);
  // The frame is complete on the last hull; FEATURES that come after it are late.
  for (int i = 0; i < 400 && agg.merged_frames() < 1; i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(agg.merged_frames(), 1u);
  agg.stop();
  {
    std::lock_guard<std::mutex> g(sink.mu);
    ASSERT_EQ(sink.frames.size(), 1u);
    const pipeline::Frame& f = sink.frames[0];
    EXPECT_EQ(f.seq, seq);
    EXPECT_TRUE(f.merged);
    EXPECT_EQ(f.occupied, 16u);
    EXPECT_GE(f.t_merged_ns, f.t_assembled_ns);
    ASSERT_NE(f.node(1), nullptr);
    ASSERT_NE(f.node(2), nullptr);
    EXPECT_EQ(f.node(1)->rle.empty(), false) << "the partial hulls travel with the frame";
    uint64_t feats = f.node(1)->features.size();
    EXPECT_GE(feats, 1u);
    EXPECT_EQ(f.node(1)->features[0].camera, 0);
    EXPECT_FLOAT_EQ(f.node(1)->features[0].features[0].u, 10.5f);
    ASSERT_EQ(f.node(1)->stats.size(), 1u);
    EXPECT_EQ(f.node(1)->stats[0].frames, 60u);
    EXPECT_TRUE(f.node(2)->features.empty());
    Report r = agg.report();
    EXPECT_EQ(r.nodes[0].features + r.nodes[0].features_late, 2u) << "both FEATURES accounted";
    EXPECT_EQ(r.nodes[0].features, feats);
    EXPECT_DOUBLE_EQ(r.nodes[0].edge_frame_ms, 2.0);
    // The triangulation stage runs after merge (the rig has features and [triangulation] enabled).
    EXPECT_TRUE(f.triangulated);
    EXPECT_EQ(f.features3d.size(), 5u);
    // The fitting stage runs after triangulation ([fitting] enabled): one frame is an initialization
    // frame at most, so no pose yet.
    EXPECT_EQ(f.pose.state, pipeline::PoseState::None);
    for (const char* stage : {"assemble", "merge", "triangulate", "fit", "test-sink", "record", "figures"}) {
      const pipeline::StageReport* s = r.pipeline.stage(stage);
      ASSERT_NE(s, nullptr) << stage;
      EXPECT_EQ(s->queue.dropped, 0u) << stage;
    }
    EXPECT_EQ(r.pipeline.stage("merge")->processed, 1u);
    EXPECT_EQ(r.pipeline.stage("record")->processed, 1u);
    EXPECT_GE(r.pipeline.stage("assemble")->processed, 5u);
    std::vector<std::string> order;
    for (const auto& s : r.pipeline.stages) order.push_back(s.name);
    EXPECT_EQ(order, (std::vector<std::string>{"assemble", "merge", "triangulate", "fit", "test-sink",
                                               "record", "figures"}));
    EXPECT_EQ(r.pipeline.stage("triangulate")->processed, 1u);
    EXPECT_EQ(r.pipeline.stage("fit")->processed, 1u);
  }
  record::Reader reader = record::Reader::open(rec.dir());
  const record::Reader::Summary& s = reader.summary();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.frames, 1u);
  EXPECT_EQ(s.features, agg.report().nodes[0].features);
  EXPECT_EQ(s.stats, 1u);
  EXPECT_EQ(s.first_seq, seq);
}

// The record stage writes a POSE record (layout voxcap.pose15/1) for every frame the fitting stage ran
// on, state none (initialization) included, and none for frames it did not run on.
TEST(RecordStage, WritesThePoseOfEveryFittedFrame) {
  TmpDir tmp;
  const config::RigConfig rig = make_rig(tmp.p);
  RecordStage stage(tmp.p / "rec");
  pipeline::StageContext ctx;
  ctx.rig = &rig;
  stage.configure(ctx);
  std::vector<pipeline::Pose> sent;
  for (uint64_t seq = 100; seq < 110; ++seq) {
    pipeline::Frame f;
    f.seq = seq;
    f.t_trigger_ns = 1000 * seq;
    if (seq >= 102) {  // 100, 101: no fitting stage ran; 102, 103: initialization frames
      f.pose.t_fitted_ns = 1000 * seq + 7;
      f.pose.state = seq < 104 ? pipeline::PoseState::None : pipeline::PoseState::Fitted;
      f.pose.body_version = seq < 104 ? 0 : 1;
      f.pose.confidence = 0.5f;
      for (size_t j = 0; j < static_cast<size_t>(pipeline::kPoseJointCount); ++j)
        f.pose.p_world[j] = {0.1 * double(j), -0.01 * double(seq), 1.0};
      sent.push_back(f.pose);
    }
    stage.process(f);
  }
  stage.stop();
  record::Reader reader = record::Reader::open(stage.dir());
  EXPECT_EQ(reader.summary_ref().frames, 10u);
  EXPECT_EQ(reader.summary_ref().poses, 8u);
  EXPECT_EQ(reader.summary_ref().pose_layout, record::kPoseLayout);
  record::Record r;
  size_t k = 0, with_names = 0;
  while (reader.next(r)) {
    const auto* p = std::get_if<record::PoseRecord>(&r);
    if (!p) continue;
    ASSERT_LT(k, sent.size());
    with_names += p->joint_names.empty() ? 0 : 1;
    pipeline::Pose back;
    std::string why;
    ASSERT_TRUE(record::from_record(*p, &back, &why)) << why;
    EXPECT_EQ(p->seq, 102 + k);
    EXPECT_EQ(back.state, sent[k].state);
    EXPECT_EQ(back.body_version, sent[k].body_version);
    EXPECT_EQ(back.t_fitted_ns, sent[k].t_fitted_ns);
    EXPECT_EQ(back.p_world, sent[k].p_world);
    ++k;
  }
  EXPECT_EQ(k, sent.size());
  EXPECT_EQ(with_names, 1u) << "the joint names ride in the first pose record only";
}

// Issue #13: a HULL with seq 2^62 from a connected node moved the assembler's high-water mark and
// every real hull after it was late (0 fps, nothing logged). Now a HULL or FEATURES is taken only from
// a running node and for a seq the host has pulsed; the others are counted per node by reason, and
// the real frames go on merging complete.
TEST(Aggregator, RefusesHullsFromANodeNotRunningOrForASeqNeverPulsed) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  std::mutex lmu;
  std::vector<std::string> lines;
  o.log = [&](log::Level, const std::string& l) {
    std::lock_guard<std::mutex> g(lmu);
    lines.push_back(l);
  };
  config::RigConfig rig = make_rig(tmp.p);
  uint32_t gid = grid_id(rig.grid);
  Aggregator agg(rig, o);
  agg.start();
  FakeEdge e1(agg.port(), 1), e2(agg.port(), 2);
  const uint64_t origin = static_cast<uint64_t>(bring_up(agg, e1, e2));
  std::vector<uint8_t> a(8, 0xF0), b(8, 0x3C);
  const uint64_t huge = uint64_t{1} << 62;
  for (uint64_t k = 0; k < 30; k++) {
    const uint64_t seq = origin + k, t = vc::monotonic_ns();
    agg.note_pulse(seq, t);
    if (k == 3) {
      e1.hull(huge, 0, gid, a);  // the attack: the seq of no pulse, a trigger time of 0
      e1.features(huge, 0, 0);
      e2.hull(seq + 5, t, gid, b);  // five pulses ahead: never pulsed either
    }
    e1.hull(seq, t, gid, a);
    e2.hull(seq, t, gid, b);
    for (int i = 0; i < 400 && agg.merged_frames() < k + 1; i++)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_EQ(agg.merged_frames(), k + 1) << "frame " << seq;
  }
  // A node that is no longer running: its hull is refused too.
  e2.state(VC_STATE_READY);
  for (int i = 0; i < 200 && agg.all_running(); i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  agg.note_pulse(origin + 30, vc::monotonic_ns());
  e2.hull(origin + 30, vc::monotonic_ns(), gid, b);
  Report r;
  for (int i = 0; i < 400; i++) {
    r = agg.report();
    if (r.nodes[1].refused["not_running"] == 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(r.complete, 30u);
  EXPECT_EQ(r.nodes[0].refused["unpulsed"], 2u);
  EXPECT_EQ(r.nodes[1].refused["unpulsed"], 1u);
  EXPECT_EQ(r.nodes[1].refused["not_running"], 1u);
  EXPECT_EQ(r.nodes[0].late + r.nodes[1].late, 0u);
  EXPECT_FALSE(r.merging_stopped());
  agg.stop();
  std::lock_guard<std::mutex> g(lmu);
  size_t said = 0;
  for (const std::string& l : lines)
    if (l.find("refused") != std::string::npos && l.find("never pulsed") != std::string::npos) said++;
  EXPECT_EQ(said, 2u) << "logged once per node and reason";
}

// Protocol 2.4: FRAMEs are taken only from a running node that a GRAB in force asked, for a pulsed
// seq the GRAB selects, a camera and format it asked for; everything else is counted and dropped, and
// hulls keep merging meanwhile.
TEST(Aggregator, TakesOnlyTheFramesAGrabAskedForAndKeepsMerging) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  config::RigConfig rig = make_rig(tmp.p);
  uint32_t gid = grid_id(rig.grid);
  Aggregator agg(rig, o);
  std::mutex fmu;
  std::vector<CameraFrame> got;
  agg.set_frame_sink([&](CameraFrame&& f) {
    std::lock_guard<std::mutex> g(fmu);
    got.push_back(std::move(f));
  });
  agg.start();
  FakeEdge e1(agg.port(), 1), e2(agg.port(), 2);
  const uint64_t origin = static_cast<uint64_t>(bring_up(agg, e1, e2));
  std::vector<uint8_t> a(8, 0xF0), b(8, 0x3C);
  auto pulse = [&](uint64_t seq) {
    const uint64_t t = vc::monotonic_ns();
    agg.note_pulse(seq, t);
    e1.hull(seq, t, gid, a);
    e2.hull(seq, t, gid, b);
    return t;
  };
  uint64_t seq = origin;
  uint64_t t = pulse(seq);
  e1.frame(seq, t, 0, VC_FRAME_GRAY8);  // before any GRAB: unrequested
  for (int i = 0; i < 400 && agg.report().nodes[0].refused["unrequested"] < 1; i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  agg.grab(2, VC_FRAME_GRAY8);
  ASSERT_EQ(e1.expect(VC_MSG_GRAB), 0);
  EXPECT_EQ(e1.last_grab.every, 2);
  EXPECT_EQ(e1.last_grab.format, VC_FRAME_GRAY8);
  EXPECT_EQ(e1.last_grab.cameras, 3);
  EXPECT_EQ(e1.last_grab.count, 0u);
  ASSERT_EQ(e2.expect(VC_MSG_GRAB), 0);
  size_t wanted = 0;
  for (int k = 1; k <= 10; k++) {
    t = pulse(++seq);
    for (uint16_t c = 0; c < 2; c++) {
      e1.frame(seq, t, c, VC_FRAME_GRAY8);  // odd seqs: not selected
      e2.frame(seq, t, c, VC_FRAME_GRAY8);
    }
    if (seq % 2 == 0) wanted += 4;
  }
  e1.frame(seq + 2, t, 0, VC_FRAME_GRAY8);        // two ahead of the last pulse: never pulsed
  e1.frame(seq - seq % 2, t, 1, VC_FRAME_RGB8);   // a format not asked for
  e2.frame(seq - seq % 2, t, 2, VC_FRAME_GRAY8);  // a camera the node does not have
  Report r;
  for (int i = 0; i < 400; i++) {
    r = agg.report();
    if (r.nodes[0].refused["unpulsed"] == 1 && r.nodes[1].refused["unrequested"] >= 6 && r.frames >= 11)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(r.nodes[0].frames + r.nodes[1].frames, wanted);
  EXPECT_EQ(r.nodes[0].refused["unrequested"], 1u + 10 + 1);  // before GRAB, 5 odd seqs x 2, rgb8
  EXPECT_EQ(r.nodes[1].refused["unrequested"], 10u + 1);
  EXPECT_EQ(r.nodes[0].refused["unpulsed"], 1u);
  EXPECT_EQ(r.frames, 11u) << "hulls kept merging";
  EXPECT_EQ(r.complete, 11u);
  {
    std::lock_guard<std::mutex> g(fmu);
    ASSERT_EQ(got.size(), wanted);
    for (const CameraFrame& f : got) {
      EXPECT_EQ(f.seq % 2, 0u);
      EXPECT_EQ(f.width, 64);
      EXPECT_EQ(f.height, 48);
      EXPECT_EQ(f.camera, rig.nodes[f.node_id - 1].cameras[f.node_camera]);
      ASSERT_EQ(f.pixels.size(), 64u * 48);
      for (size_t i = 0; i < f.pixels.size(); i += 37) ASSERT_EQ(f.pixels[i], (f.seq + i) % 251);
    }
  }
  // every 0 stops: the nodes are told, and later FRAMEs are unrequested.
  agg.grab(0);
  ASSERT_EQ(e1.expect(VC_MSG_GRAB), 0);
  EXPECT_EQ(e1.last_grab.every, 0);
  t = pulse(seq + 1);
  e1.frame(seq + 1 - (seq + 1) % 2, t, 0, VC_FRAME_GRAY8);
  for (int i = 0; i < 400 && agg.report().nodes[0].refused["unrequested"] < 13; i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(agg.report().nodes[0].refused["unrequested"], 13u);
  agg.stop();
}

// Issue #13: a duplicate HELLO with a live node's id replaced the real node (and got its calibration);
// nodes[].address was read and never checked. Both are refused now, and the live node keeps its session.
TEST(Aggregator, RefusesADuplicateHelloAndAHelloFromAnotherAddress) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  config::RigConfig rig = make_rig(tmp.p);
  rig.nodes[0].address = "127.0.0.1";
  rig.nodes[1].address = "127.0.0.2";  // the fake edges all come from 127.0.0.1
  Aggregator agg(rig, o);
  agg.start();
  FakeEdge live(agg.port(), 1);
  ASSERT_EQ(live.expect(VC_MSG_CONFIG), 0);
  for (int k = 0; k < 3; k++) {
    FakeEdge dup(agg.port(), 1);
    EXPECT_EQ(dup.expect(VC_MSG_CONFIG, 1000), -2) << "closed without CONFIG";
  }
  FakeEdge elsewhere(agg.port(), 2);
  EXPECT_EQ(elsewhere.expect(VC_MSG_CONFIG, 1000), -2);
  live.state(VC_STATE_CONFIGURED);
  EXPECT_GE(live.expect(VC_MSG_BACKGROUND), 0) << "the live node's session goes on";
  Report r = agg.report();
  EXPECT_TRUE(r.nodes[0].connected);
  EXPECT_EQ(r.nodes[0].joins, 1u);
  EXPECT_EQ(r.nodes[0].leaves, 0u);
  EXPECT_EQ(r.nodes[0].hellos_refused, 3u);
  EXPECT_EQ(r.nodes[1].hellos_refused, 1u);
  EXPECT_FALSE(r.nodes[1].connected);
  agg.stop();
  EXPECT_EQ(resolve_ipv4("localhost"), std::vector<std::string>{"127.0.0.1"});
  EXPECT_TRUE(resolve_ipv4("any").empty());
}

TEST(Aggregator, RejectsUnknownNodesAndWrongCameras) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  Aggregator agg(make_rig(tmp.p), o);
  agg.start();
  FakeEdge stranger(agg.port(), 9);
  EXPECT_EQ(stranger.expect(VC_MSG_CONFIG, 1000), -2);  // closed without CONFIG
  FakeEdge wrong(agg.port(), 1, 320);
  EXPECT_EQ(wrong.expect(VC_MSG_CONFIG, 1000), -2);
  agg.stop();
}

}  // namespace
}  // namespace vc::aggregator

namespace vc::aggregator {
namespace {

// Issue #13: MAC rejections were counted per connection only (gone with it) and not in the report.
// The session server tells the handler the node whose accepted connection a dropped message came on;
// the node's report keeps the counts by reason across its connections.
TEST(Aggregator, CountsMacRejectionsPerNodeByReasonAcrossConnections) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  Aggregator agg(make_rig(tmp.p), o);
  agg.on_mac_rejected(11, 2, VC_PROTO_EMAC);
  agg.on_mac_rejected(11, 2, VC_PROTO_EMAC);
  agg.on_mac_rejected(12, 2, VC_PROTO_EREPLAY);  // a later connection of the same node
  agg.on_mac_rejected(13, 1, VC_PROTO_EORDER);
  agg.on_mac_rejected(14, 9, VC_PROTO_EMAC);  // no such node: counted by the server only
  const Report r = agg.report();
  ASSERT_EQ(r.nodes.size(), 2u);
  EXPECT_EQ(r.nodes[0].id, 1u);
  EXPECT_EQ(r.nodes[0].mac_rejected.forged, 0u);
  EXPECT_EQ(r.nodes[0].mac_rejected.reordered, 1u);
  EXPECT_EQ(r.nodes[1].mac_rejected.forged, 2u);
  EXPECT_EQ(r.nodes[1].mac_rejected.replayed, 1u);
  EXPECT_EQ(r.nodes[1].mac_rejected.reordered, 0u);
  EXPECT_EQ(r.nodes[1].mac_rejected.total(), 3u);
}

// The rig key named in rig.toml is read as the host reads it, and a bad one is bad input (ConfigError
// naming the key, one line): missing, open to group or others, malformed. voxcap config check runs the
// same function.
TEST(Aggregator, ABadKeyFileIsAConfigErrorNamingTheKey) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  config::RigConfig rig = make_rig(tmp.p);
  EXPECT_TRUE(load_rig_key(rig).empty()) << "no key: a keyless (loopback) rig";
  auto expect_error = [&](const std::string& what) {
    SCOPED_TRACE(what);
    try {
      Aggregator agg(rig, o);
      ADD_FAILURE() << "no error";
    } catch (const config::ConfigError& e) {
      EXPECT_EQ(e.key(), "key");
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  };
  rig.key_path = tmp.p / "rig.key";
  expect_error("No such file");
  std::ofstream(rig.key_path) << std::string(64, 'a') << "\n";
  fs::permissions(rig.key_path, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  expect_error("lets group or others at it");
  fs::permissions(rig.key_path, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(load_rig_key(rig).size(), size_t{VC_AUTH_KEY_SIZE});
  std::ofstream(rig.key_path) << "not a key\n";
  expect_error("not one line of 64 hex digits");
}

// A node's side of a keyed connection (proto/SPEC.md "Authentication"), with the proto library only.
struct KeyedEdge {
  int fd = -1;
  uint16_t id;
  vc_decoder* dec = new_decoder();
  vc_mac tx{}, rx{};
  KeyedEdge(uint16_t port, uint16_t node) : id(node) {
    fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  }
  ~KeyedEdge() {
    vc_decoder_free(dec);
    close(fd);
  }
  bool send_all(const uint8_t* b, size_t n) { return ::send(fd, b, n, MSG_NOSIGNAL) == (ssize_t)n; }
  // The next message (1), the peer closed (-2) or nothing in ms (-1).
  int next(vc_msg* m, int ms = 3000) {
    auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    uint8_t b[8192];
    for (;;) {
      int rc = vc_decoder_next(dec, m);
      if (rc == 1) return 1;
      if (rc < 0) return -2;
      if (std::chrono::steady_clock::now() > end) return -1;
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      ssize_t n = recv(fd, b, sizeof(b), 0);
      if (n <= 0) return -2;
      size_t used = 0;
      for (size_t off = 0; off < (size_t)n; off += used)
        if (vc_decoder_feed(dec, b + off, n - off, &used) < 0) return -2;
    }
  }
  // HELLO offering the key, the challenge, the host's proof checked, ours; true when the host proved it.
  bool handshake(const uint8_t* key) {
    vc_hello h{};
    h.node_id = id;
    h.capabilities = VC_CAP_HULL | VC_CAP_AUTH;
    h.camera_count = 2;
    for (int c = 0; c < 2; c++) {
      h.cameras[c].width = 64;
      h.cameras[c].height = 48;
    }
    uint8_t buf[512];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = id;
    if (vc_encode_hello(buf, sizeof buf, &len, &hdr, &h) != 0 || !send_all(buf, len)) return false;
    uint8_t nn[VC_AUTH_NONCE_SIZE], nh[VC_AUTH_NONCE_SIZE];
    vc_auth_random(nn, sizeof nn);
    vc_auth_msg a{};
    a.step = VC_AUTH_CHALLENGE;
    std::memcpy(a.nonce, nn, sizeof nn);
    if (vc_encode_auth(buf, sizeof buf, &len, &hdr, &a) != 0 || !send_all(buf, len)) return false;
    vc_msg m{};
    if (next(&m) != 1 || m.hdr.type != VC_MSG_AUTH || m.u.auth.step != VC_AUTH_RESPONSE) return false;
    std::memcpy(nh, m.u.auth.nonce, sizeof nh);
    if (!vc_auth_verify(m.u.auth.proof, key, VC_AUTH_ROLE_HOST, id, nn, nh)) return false;
    vc_auth_msg p{};
    p.step = VC_AUTH_PROOF;
    vc_auth_prove(p.proof, key, VC_AUTH_ROLE_NODE, id, nn, nh);
    if (vc_encode_auth(buf, sizeof buf, &len, &hdr, &p) != 0 || !send_all(buf, len)) return false;
    vc_auth_session(key, id, nn, nh, &tx, &rx);
    vc_decoder_set_mac(dec, &rx);
    return true;
  }
  // Waits for a message of `type`: 1, -2 when closed, -1 when it did not come in ms.
  int expect(uint16_t type, int ms = 3000) {
    vc_msg m{};
    for (;;) {
      int rc = next(&m, ms);
      if (rc != 1) return rc;
      if (m.hdr.type == type) return 1;
    }
  }
  void heartbeat(uint32_t state) {
    std::vector<uint8_t> b(VC_PROTO_HEADER_SIZE + 64);
    size_t len = 0, out = 0;
    vc_header hdr{};
    hdr.node_id = id;
    vc_heartbeat hb{1, state};
    ASSERT_EQ(vc_encode_heartbeat(b.data(), b.size(), &len, &hdr, &hb), 0);
    ASSERT_EQ(vc_mac_seal(&tx, b.data(), len, b.size(), &out), 0);
    ASSERT_TRUE(send_all(b.data(), out));
  }
};

// Deliver 1 of issue #13: a second HELLO for a connected node is refused, the live node stays, unless
// it proves the key and the old connection is dead: on a keyed rig a HELLO that proves the key takes
// the node from a connection silent for more than half the heartbeat timeout, never from a live one.
TEST(Aggregator, KeyedHelloReplacesOnlyADeadConnectionOfItsNode) {
  ASSERT_EQ(vc_auth_init(), 0);
  TmpDir tmp;
  std::vector<std::string> lines;
  std::mutex mu;
  Options o;
  o.start_trigger = false;
  o.log = [&](log::Level, const std::string& l) {
    std::lock_guard<std::mutex> g(mu);
    lines.push_back(l);
  };
  config::RigConfig rig = make_rig(tmp.p);
  rig.key_path = tmp.p / "rig.key";
  uint8_t key[VC_AUTH_KEY_SIZE];
  char why[256];
  ASSERT_EQ(vc_key_write(rig.key_path.c_str(), false, key, why, sizeof why), 0) << why;
  Aggregator agg(rig, o);
  agg.start();
  KeyedEdge live(agg.port(), 1);
  ASSERT_TRUE(live.handshake(key));
  ASSERT_EQ(live.expect(VC_MSG_CONFIG), 1);
  {  // the same key, while the live node talks: refused, the live node stays
    KeyedEdge second(agg.port(), 1);
    live.heartbeat(VC_STATE_IDLE);
    ASSERT_TRUE(second.handshake(key));
    EXPECT_EQ(second.expect(VC_MSG_CONFIG, 1000), -2) << "refused and closed, no CONFIG";
  }
  Report r = agg.report();
  EXPECT_EQ(r.nodes[0].hellos_refused, 1u);
  EXPECT_EQ(r.nodes[0].joins, 1u);
  EXPECT_TRUE(r.nodes[0].connected);
  // The live node goes silent for more than half the heartbeat timeout (2 s): a HELLO that proves the
  // key takes its place (an edge that restarted before its old connection was seen to die).
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));
  KeyedEdge restarted(agg.port(), 1);
  ASSERT_TRUE(restarted.handshake(key));
  EXPECT_EQ(restarted.expect(VC_MSG_CONFIG), 1);
  EXPECT_EQ(live.expect(VC_MSG_CONFIG, 1000), -2) << "the silent connection was closed";
  r = agg.report();
  EXPECT_EQ(r.nodes[0].joins, 2u);
  EXPECT_EQ(r.nodes[0].hellos_refused, 1u);
  EXPECT_TRUE(r.nodes[0].connected);
  agg.stop();
  std::lock_guard<std::mutex> g(mu);
  bool said = false;
  for (const std::string& l : lines) said = said || l.find("proved the key from") != std::string::npos;
  EXPECT_TRUE(said) << "the replacement is logged";
}

// rig.toml [network] heartbeat_interval_ms and heartbeat_timeout_ms reach the session server: a node
// silent for longer than the server's default timeout (2 s) stays connected under a rig's 60 s.
TEST(Aggregator, TheRigsHeartbeatTimeoutIsTheSessionServers) {
  TmpDir tmp;
  Options o;
  o.start_trigger = false;
  o.log = [](log::Level, const std::string&) {};
  config::RigConfig rig = make_rig(tmp.p);
  ASSERT_EQ(rig.network.heartbeat_timeout_ms, session::ServerOptions{}.heartbeat_timeout_ms);
  rig.network.heartbeat_timeout_ms = 60'000;
  Aggregator agg(rig, o);
  agg.start();
  FakeEdge e(agg.port(), 1);
  ASSERT_EQ(e.expect(VC_MSG_CONFIG), 0);
  ASSERT_TRUE(agg.report().nodes[0].connected);
  // Silent past the default timeout (and a loaded machine's poll delays): with it the node is dropped.
  std::this_thread::sleep_for(
      std::chrono::milliseconds(session::ServerOptions{}.heartbeat_timeout_ms + 1500));
  const Report r = agg.report();
  EXPECT_TRUE(r.nodes[0].connected);
  EXPECT_EQ(r.nodes[0].leaves, 0u);
  EXPECT_EQ(r.server.timeouts, 0u);
  EXPECT_GE(e.expect(VC_MSG_HEARTBEAT), 0) << "the host still talks to it";
  agg.stop();
}

// Deliver 1: a keyless rig (allowed only when every address is loopback: RigConfig::valid) says so
// in its log.
TEST(Aggregator, AKeylessRigSaysSoInItsLog) {
  TmpDir tmp;
  std::vector<std::string> lines;
  Options o;
  o.start_trigger = false;
  o.log = [&](log::Level level, const std::string& l) {
    if (level == log::Level::warn) lines.push_back(l);
  };
  Aggregator agg(make_rig(tmp.p), o);
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines[0].find("no rig key: control is not authenticated"), std::string::npos) << lines[0];
}

}  // namespace
}  // namespace vc::aggregator
