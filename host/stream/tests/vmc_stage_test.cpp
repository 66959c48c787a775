// The VMC stage: frames picked by seq at the configured rate (capped at the rig's), one bundle per
// picked frame with the bones once there is a pose, the last pose held, send errors and bad poses
// counted while the stage goes on; and liblo's bundles received on 127.0.0.1 as a VMC receiver
// decodes them.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "vmc_receiver.hpp"
#include "voxcap/body/joints.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/stream/vmc_stage.hpp"

namespace vc::stream {
namespace {

using glm::dvec3;

pipeline::Pose rest_pose(double x = 0.1) {
  body::StandardSegments seg;
  seg.hips_to_spine_m = 0.01;
  seg.spine_to_neck_m = 0.5;
  const body::Skeleton sk = body::standard_skeleton(seg);
  std::vector<dvec3> p;
  body::forward_kinematics(sk, body::rest_pose(sk, {x, 0, 0.95}), &p);
  pipeline::Pose out;
  out.state = pipeline::PoseState::Fitted;
  out.body_version = 1;
  for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
    const dvec3& q = p.at(static_cast<size_t>(body::joint_from_name(pipeline::pose_joint_name(j))));
    out.p_world[static_cast<size_t>(j)] = {q.x, q.y, q.z};
  }
  return out;
}

struct Harness {
  config::RigConfig rig;
  MemorySink* sink = nullptr;
  std::unique_ptr<VmcStage> stage;
  std::vector<std::string> lines;

  Harness(double rig_hz, double vmc_hz) {
    rig.trigger.rate_hz = rig_hz;
    config::VmcOptions o;
    o.enabled = true;
    o.rate_hz = vmc_hz;
    auto s = std::make_unique<MemorySink>();
    sink = s.get();
    stage = std::make_unique<VmcStage>(o, std::move(s));
    pipeline::StageContext ctx;
    ctx.rig = &rig;
    ctx.log = [this](log::Level, const std::string& line) { lines.push_back(line); };
    stage->configure(ctx);
    stage->start();
  }
  void frame(uint64_t seq, const pipeline::Pose& pose) {
    pipeline::Frame f;
    f.seq = seq;
    f.t_trigger_ns = 1'000'000'000ULL + seq * 1'000'000'000ULL / static_cast<uint64_t>(rig.trigger.rate_hz);
    f.pose = pose;
    stage->process(f);
  }
};

TEST(VmcStage, SendsEveryFrameAtTheRigsRateAndCapsAHigherRateAtIt) {
  Harness r(60, 240);
  for (uint64_t s = 100; s < 160; ++s) r.frame(s, rest_pose());
  const VmcCounters c = r.stage->counters();
  EXPECT_DOUBLE_EQ(c.rate_hz, 60);
  EXPECT_EQ(c.frames, 60u);
  EXPECT_EQ(c.sent, 60u);
  EXPECT_EQ(c.with_pose, 60u);
  EXPECT_EQ(r.sink->packets.size(), 60u);
  // T from the trigger clock: seconds since the first frame sent.
  EXPECT_DOUBLE_EQ(r.sink->packets.front().time_s, 0.0);
  EXPECT_NEAR(r.sink->packets.back().time_s, 59.0 / 60.0, 1e-6);
  EXPECT_THAT(r.lines, ::testing::Contains(::testing::HasSubstr("above the rig's 60 Hz")));
}

TEST(VmcStage, PicksFramesBySeqAtTheConfiguredRate) {
  for (const auto& [rig_hz, vmc_hz] : {std::pair{60.0, 30.0}, {60.0, 45.0}, {120.0, 60.0}, {60.0, 7.0}}) {
    Harness r(rig_hz, vmc_hz);
    const uint64_t n = 600;
    for (uint64_t s = 1000; s < 1000 + n; ++s) r.frame(s, rest_pose());
    const double want = static_cast<double>(n) * vmc_hz / rig_hz;
    EXPECT_NEAR(static_cast<double>(r.stage->counters().sent), want, 1.0) << rig_hz << " " << vmc_hz;
    EXPECT_EQ(r.stage->counters().frames, n);
    // Evenly: the gaps between sent frames differ by at most one frame period (after the first, which
    // is sent at once: its gap to the next is what is left of its slot).
    std::set<long> gaps;
    for (size_t k = 2; k < r.sink->packets.size(); ++k)
      gaps.insert(std::lround((r.sink->packets[k].time_s - r.sink->packets[k - 1].time_s) * rig_hz));
    ASSERT_FALSE(gaps.empty());
    EXPECT_LE(*gaps.rbegin() - *gaps.begin(), 1) << rig_hz << " " << vmc_hz;
  }
  // A gap in seq (frames dropped before the stage) sends the next frame at once; a frame older than
  // the last one sent (out of seq order) is not sent.
  Harness r(60, 30);
  r.frame(10, rest_pose());
  r.frame(11, rest_pose());
  r.frame(15, rest_pose());
  r.frame(12, rest_pose());
  r.frame(16, rest_pose());
  r.frame(17, rest_pose());
  EXPECT_EQ(r.stage->counters().sent, 3u);  // 10, 15, 16
  EXPECT_EQ(r.stage->counters().stale, 1u);
  EXPECT_EQ(r.stage->counters().frames, 6u);
  for (size_t k = 1; k < r.sink->packets.size(); ++k)
    EXPECT_GT(r.sink->packets[k].time_s, r.sink->packets[k - 1].time_s);
}

TEST(VmcStage, SaysWaitingBeforeTheFirstPoseThenSendsBonesAndHoldsTheLastPose) {
  Harness r(60, 60);
  r.frame(1, pipeline::Pose{});  // the fitter is initializing
  pipeline::Pose predicted = rest_pose(0.3);
  predicted.state = pipeline::PoseState::Predicted;
  r.frame(2, rest_pose(0.2));
  r.frame(3, predicted);
  r.frame(4, pipeline::Pose{});  // lost: held
  ASSERT_EQ(r.sink->packets.size(), 4u);
  const auto& p = r.sink->packets;
  EXPECT_FALSE(p[0].has_pose);
  EXPECT_EQ(p[0].loaded, 0);
  EXPECT_EQ(p[0].calibration_state, 1);
  EXPECT_TRUE(p[1].has_pose);
  EXPECT_EQ(p[1].loaded, 1);
  EXPECT_EQ(p[1].calibration_state, 3);
  EXPECT_EQ(p[1].tracking, 1);
  EXPECT_NEAR(p[1].pose.bones[0].p.x, -0.2, 1e-12);  // Hips, x_u = -x
  EXPECT_EQ(p[2].tracking, 0);                       // predicted
  EXPECT_NEAR(p[2].pose.bones[0].p.x, -0.3, 1e-12);
  EXPECT_TRUE(p[3].has_pose);  // held: the last pose, tracking lost
  EXPECT_EQ(p[3].tracking, 0);
  EXPECT_NEAR(p[3].pose.bones[0].p.x, -0.3, 1e-12);
  const VmcCounters c = r.stage->counters();
  EXPECT_EQ(c.with_pose, 3u);
  EXPECT_EQ(c.held, 1u);
}

TEST(VmcStage, SendErrorsAndBadPosesAreCountedAndLoggedAtMostOnceASecond) {
  Harness r(60, 60);
  r.sink->fail = true;
  for (uint64_t s = 0; s < 100; ++s) r.frame(s, rest_pose());
  pipeline::Pose nan = rest_pose();
  nan.p_world[0][2] = std::nan("");
  r.frame(100, nan);
  r.sink->fail = false;
  r.frame(101, nan);  // not convertible: the last good pose is held and sent
  r.frame(102, rest_pose());
  const VmcCounters c = r.stage->counters();
  EXPECT_EQ(c.send_errors, 101u);
  EXPECT_EQ(c.bad_poses, 2u);
  EXPECT_EQ(c.sent, 2u);
  size_t warnings = 0;
  for (const std::string& l : r.lines) warnings += l.find("to memory:") != std::string::npos;
  EXPECT_EQ(warnings, 1u);  // all within one second of wall time
  r.stage->stop();
  EXPECT_THAT(r.lines.back(), ::testing::HasSubstr("101 of 103 bundles not sent, 2 poses not convertible"));
}

TEST(VmcStage, RefusesBadOptionsInConfigure) {
  config::VmcOptions o;
  o.rate_hz = 0;
  VmcStage s(o, std::make_unique<MemorySink>());
  EXPECT_THROW(s.configure({}), std::invalid_argument);
}

// liblo end to end on loopback: the bundles a VMC receiver decodes, with the VMC addresses, argument
// types and bone names.
TEST(LibloSink, AReceiverOnLoopbackDecodesTheBundles) {
  testing::VmcReceiver rx;
  config::VmcOptions o;
  o.enabled = true;
  o.target = {"127.0.0.1", rx.port()};
  VmcStage stage(o);  // the real sink
  config::RigConfig rig;
  rig.trigger.rate_hz = 60;
  pipeline::StageContext ctx;
  ctx.rig = &rig;
  ctx.log = [](log::Level, const std::string&) {};
  stage.configure(ctx);
  pipeline::Frame f;
  f.seq = 7;
  f.t_trigger_ns = 7 * 16'666'667ULL;
  stage.process(f);  // no pose yet
  for (uint64_t s = 8; s < 20; ++s) {
    f.seq = s;
    f.t_trigger_ns = s * 16'666'667ULL;
    f.pose = rest_pose();
    stage.process(f);
  }
  ASSERT_TRUE(rx.wait_for(13, 5000)) << rx.count();
  EXPECT_EQ(stage.counters().sent, 13u);
  const auto bundles = rx.bundles();
  ASSERT_EQ(bundles.size(), 13u);
  EXPECT_EQ(rx.not_bundles(), 0u);
  // Before the first pose: OK (loaded 0, waiting for calibration) and T only.
  ASSERT_EQ(bundles[0].size(), 2u);
  EXPECT_EQ(bundles[0][0].path, "/VMC/Ext/OK");
  EXPECT_EQ(bundles[0][0].types, "iiii");
  EXPECT_EQ(bundles[0][0].i, (std::vector<int>{0, 1, 0, 0}));
  EXPECT_EQ(bundles[0][1].path, "/VMC/Ext/T");
  EXPECT_EQ(bundles[0][1].types, "f");
  // With a pose: Root, the 19 bones by name, OK, T.
  const auto& b = bundles[1];
  ASSERT_EQ(b.size(), static_cast<size_t>(kVmcBoneCount) + 3);
  EXPECT_EQ(b[0].path, "/VMC/Ext/Root/Pos");
  EXPECT_EQ(b[0].types, "sfffffff");
  EXPECT_EQ(b[0].s, (std::vector<std::string>{"root"}));
  for (int k = 0; k < kVmcBoneCount; ++k) {
    const auto& m = b[static_cast<size_t>(k) + 1];
    EXPECT_EQ(m.path, "/VMC/Ext/Bone/Pos");
    EXPECT_EQ(m.types, "sfffffff");
    ASSERT_EQ(m.s.size(), 1u);
    EXPECT_EQ(m.s[0], vmc_bone_name(k));
    EXPECT_NEAR(m.f[6], 1.0, 1e-6);  // the rest pose: identity, q.w = 1
  }
  EXPECT_NEAR(b[1].f[1], 0.95, 1e-6);  // Hips' height: Unity's y
  EXPECT_EQ(b[kVmcBoneCount + 1].path, "/VMC/Ext/OK");
  EXPECT_EQ(b[kVmcBoneCount + 1].i, (std::vector<int>{1, 3, 0, 1}));
  EXPECT_EQ(b[kVmcBoneCount + 2].path, "/VMC/Ext/T");
  EXPECT_NEAR(bundles.back().back().f[0], 12 * 16'666'667e-9, 1e-6);  // seq 19 - seq 7
}

// "localhost" goes to IPv4's loopback (the socket is IPv4), and nobody listening is no error for UDP.
TEST(LibloSink, LocalhostIsIPv4AndNobodyListeningIsNoError) {
  uint16_t port = 0;
  VmcPacket p;
  std::string why;
  {
    testing::VmcReceiver rx;
    port = rx.port();
    auto sink = make_liblo_sink({"localhost", port});
    EXPECT_EQ(sink->target(), "localhost:" + std::to_string(port));
    EXPECT_TRUE(sink->send(p, &why)) << why;
    EXPECT_TRUE(rx.wait_for(1, 5000));
  }
  auto sink = make_liblo_sink({"127.0.0.1", port});  // its receiver is gone
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(sink->send(p, &why)) << why;
}

}  // namespace
}  // namespace vc::stream
