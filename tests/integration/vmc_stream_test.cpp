// The VMC stream out (issue #15) end to end: the emulated rig (real voxcap-edge processes on loopback,
// the host with triangulation and fitting) streams the fitted skeleton with the VMC stage to a
// receiver in this test on 127.0.0.1, which decodes the bundles with liblo as a VMC receiver would.
// Checked: every bone by its Unity name in every posed bundle, finite values, unit quaternions, the
// Root, a performer standing upright on the floor and facing Unity's +Z, and the rate counted per
// frame: one bundle for each 30 Hz slot of the 60 Hz rig's frames the stage saw, in seq order.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <set>
#include <tuple>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "vmc_receiver.hpp"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/stream/vmc_stage.hpp"

namespace vc::stream {
namespace {

using glm::dvec3;

// Every frame that leaves the chain (block: it sees them all, in the order the VMC stage is offered
// them): seq, trigger time and pose.
class SeqProbe : public pipeline::Stage {
 public:
  std::string name() const override { return "seq-probe"; }
  void process(pipeline::Frame& f) override {
    std::lock_guard<std::mutex> g(mu);
    seqs.push_back(f.seq);
    if (seqs.size() == 1) t0_ns = f.t_trigger_ns;
    by_time[f.t_trigger_ns - std::min(f.t_trigger_ns, t0_ns)] = f.pose;
    if (f.pose.valid()) posed.insert(f.seq);
  }
  std::mutex mu;
  std::vector<uint64_t> seqs;
  uint64_t t0_ns = 0;
  std::map<uint64_t, pipeline::Pose> by_time;  // by trigger time since the first frame, ns: /VMC/Ext/T
  std::set<uint64_t> posed;
};

struct Bone {
  dvec3 p;
  glm::dquat q;
};

TEST(VmcStream, TheEmulatedRigStreamsTheFittedSkeletonToALoopbackReceiverAtTheConfiguredRate) {
  testing::VmcReceiver rx;
  emulated::Options o;
  o.nodes = 3;
  o.motion = "wave";
  o.width = 320;
  o.height = 240;
  o.grid = 64;
  o.rate_hz = 60;
  o.deadline_ms = 150;
  o.missing_policy = "degraded";
  o.truth_every = 0;
  o.keyed = false;
  o.edge_binary = VOXCAP_EDGE_BINARY;
  config::VmcOptions vo;
  vo.enabled = true;
  vo.target = {"127.0.0.1", rx.port()};
  vo.rate_hz = 30;  // half the rig's: every other seq
  VmcStage* vmc = nullptr;
  SeqProbe* probe = nullptr;
  o.stages = [&](pipeline::Pipeline& p) {
    probe = &p.tap(std::make_unique<SeqProbe>(), {4096, pipeline::Overflow::Block});
    vmc = &p.tap(std::make_unique<VmcStage>(vo), VmcStage::kQueue);
  };
  emulated::EmulatedRig rig(o);
  rig.start(60);
  rig.run_frames(120, 240);
  const emulated::Result r = rig.stop();
  ASSERT_NE(vmc, nullptr);
  const VmcCounters c = vmc->counters();
  ASSERT_GE(r.report.frames, 60u) << "merged only " << r.report.frames;
  ASSERT_TRUE(rx.wait_for(c.sent, 10000)) << rx.count() << " of " << c.sent;
  const auto bundles = rx.bundles();
  RecordProperty("bundles", std::to_string(bundles.size()));
  RecordProperty("frames", std::to_string(c.frames));
  RecordProperty("with_pose", std::to_string(c.with_pose));
  RecordProperty("held", std::to_string(c.held));
  RecordProperty("probe_posed", std::to_string(probe->posed.size()));

  // The rate, counted per frame: one bundle per 30 Hz slot (floor(seq / 2)) among the frames the stage
  // saw — all of them when its drop-oldest queue dropped none.
  const pipeline::StageReport* rep = r.stages.stage("vmc");
  ASSERT_NE(rep, nullptr);
  EXPECT_EQ(c.send_errors, 0u);
  EXPECT_EQ(c.bad_poses, 0u);
  EXPECT_EQ(bundles.size(), c.sent);  // nothing lost on loopback
  EXPECT_EQ(rx.not_bundles(), 0u);
  // The stage's rule on the seqs in the order the chain handed them on (the assembler resolves frames as
  // they complete, so a late one may follow its successor): a frame is sent when its slot is past the
  // last one sent.
  uint64_t want_sent = 0, out_of_order = 0;
  int64_t last = -1;
  for (size_t k = 0; k < probe->seqs.size(); ++k) {
    const auto slot = static_cast<int64_t>(probe->seqs[k] / 2);
    if (k > 0 && probe->seqs[k] < probe->seqs[k - 1]) ++out_of_order;
    if (slot > last) {
      ++want_sent;
      last = slot;
    }
  }
  RecordProperty("out_of_order", std::to_string(out_of_order));
  std::set<uint64_t> slots;
  for (uint64_t s : probe->seqs) slots.insert(s / 2);
  if (rep->queue.dropped == 0) {
    EXPECT_EQ(c.frames, probe->seqs.size());
    EXPECT_EQ(c.sent, want_sent);
  }
  EXPECT_LE(c.sent, slots.size());  // never two bundles for one slot
  EXPECT_GE(c.sent, slots.size() / 2) << out_of_order << " frames out of order";
  ASSERT_FALSE(probe->posed.empty()) << "the fitter gave no pose";
  EXPECT_GT(c.with_pose, 0u);

  // Every bundle: OK and T last; with a pose, the Root and every bone once, by its Unity name.
  std::set<std::string> want;
  for (int k = 0; k < kVmcBoneCount; ++k) want.insert(std::string(vmc_bone_name(k)));
  size_t posed = 0;
  double last_t = -1;
  std::vector<double> hips_y, head_above, feet_y, facing, hips_err_mm, bone_err_deg;
  size_t matched = 0;
  for (const testing::OscBundle& b : bundles) {
    ASSERT_GE(b.size(), 2u);
    const testing::OscMessage& ok = b[b.size() - 2];
    const testing::OscMessage& t = b.back();
    ASSERT_EQ(ok.path, "/VMC/Ext/OK");
    ASSERT_EQ(ok.i.size(), 4u);
    ASSERT_EQ(t.path, "/VMC/Ext/T");
    ASSERT_EQ(t.f.size(), 1u);
    EXPECT_TRUE(std::isfinite(t.f[0]));
    EXPECT_GT(t.f[0], last_t);  // in seq order: T grows
    last_t = t.f[0];
    if (b.size() == 2) {  // before the first pose
      EXPECT_EQ(ok.i[0], 0);
      EXPECT_EQ(posed, 0u) << "no bones after the first pose";
      continue;
    }
    ++posed;
    EXPECT_EQ(ok.i[0], 1);
    EXPECT_EQ(ok.i[1], 3);
    ASSERT_EQ(b.size(), static_cast<size_t>(kVmcBoneCount) + 3);
    ASSERT_EQ(b[0].path, "/VMC/Ext/Root/Pos");
    ASSERT_EQ(b[0].s, (std::vector<std::string>{"root"}));
    ASSERT_EQ(b[0].f.size(), 7u);
    EXPECT_EQ(b[0].f, (std::vector<double>{0, 0, 0, 0, 0, 0, 1}));
    std::map<std::string, Bone> bones;
    for (size_t k = 1; k + 2 < b.size(); ++k) {
      const testing::OscMessage& m = b[k];
      ASSERT_EQ(m.path, "/VMC/Ext/Bone/Pos");
      ASSERT_EQ(m.types, "sfffffff");
      for (double v : m.f) ASSERT_TRUE(std::isfinite(v)) << m.s[0];
      const double n = std::sqrt(m.f[3] * m.f[3] + m.f[4] * m.f[4] + m.f[5] * m.f[5] + m.f[6] * m.f[6]);
      EXPECT_NEAR(n, 1.0, 1e-5) << m.s[0];
      EXPECT_TRUE(
          bones.emplace(m.s[0], Bone{{m.f[0], m.f[1], m.f[2]}, {m.f[6], m.f[3], m.f[4], m.f[5]}}).second)
          << m.s[0] << " twice";
    }
    std::set<std::string> got;
    for (const auto& [name, bone] : bones) got.insert(name);
    ASSERT_EQ(got, want);
    // The receiver's forward kinematics (Root = identity at the origin) in Unity's frame.
    std::map<std::string, std::pair<dvec3, glm::dquat>> world;
    for (int k = 0; k < kVmcBoneCount; ++k) {
      const std::string name(vmc_bone_name(k));
      const int parent = vmc_bone_parent(k);
      const auto [pp, pq] = parent < 0 ? std::pair{dvec3(0), glm::dquat(1, 0, 0, 0)}
                                       : world.at(std::string(vmc_bone_name(parent)));
      world[name] = {pp + pq * bones.at(name).p, pq * bones.at(name).q};
    }
    hips_y.push_back(world["Hips"].first.y);
    head_above.push_back(world["Head"].first.y - world["Hips"].first.y);
    feet_y.push_back(std::min(world["LeftFoot"].first.y, world["RightFoot"].first.y));
    // The fitted pose this bundle came from (by its T, the trigger clock; a fitted one, not held): its
    // joints in Unity's frame where the receiver's kinematics put them, its torso facing where Hips does.
    const auto ns = static_cast<uint64_t>(std::llround(static_cast<double>(t.f[0]) * 1e9));
    const auto it = probe->by_time.lower_bound(ns > 200'000 ? ns - 200'000 : 0);
    if (it == probe->by_time.end() || it->first > ns + 200'000 || !it->second.valid()) continue;
    ++matched;
    const pipeline::Pose& fp = it->second;
    auto fitted = [&](pipeline::PoseJoint pj) {
      const auto& w = fp.p_world[static_cast<size_t>(pj)];
      return unity_from_world(dvec3(w[0], w[1], w[2]));
    };
    hips_err_mm.push_back(1000 * glm::length(world["Hips"].first - fitted(pipeline::PoseJoint::hips)));
    // Every limb bone and the neck point where the fitted ones do (the take keeps each bone's fitted
    // direction; its length is the body version's rest length).
    using PJ = pipeline::PoseJoint;
    const std::tuple<const char*, const char*, PJ, PJ> segs[] = {
        {"LeftUpperArm", "LeftLowerArm", PJ::l_shoulder, PJ::l_elbow},
        {"LeftLowerArm", "LeftHand", PJ::l_elbow, PJ::l_wrist},
        {"RightUpperArm", "RightLowerArm", PJ::r_shoulder, PJ::r_elbow},
        {"RightLowerArm", "RightHand", PJ::r_elbow, PJ::r_wrist},
        {"LeftUpperLeg", "LeftLowerLeg", PJ::l_hip, PJ::l_knee},
        {"LeftLowerLeg", "LeftFoot", PJ::l_knee, PJ::l_ankle},
        {"RightUpperLeg", "RightLowerLeg", PJ::r_hip, PJ::r_knee},
        {"RightLowerLeg", "RightFoot", PJ::r_knee, PJ::r_ankle},
        {"Neck", "Head", PJ::neck, PJ::head}};
    double worst = 0;
    for (const auto& [a, b2, ja, jb] : segs) {
      const dvec3 sent = glm::normalize(world[b2].first - world[a].first);
      const dvec3 fit = glm::normalize(fitted(jb) - fitted(ja));
      worst = std::max(worst, std::acos(std::clamp(glm::dot(sent, fit), -1.0, 1.0)) * 180 / std::numbers::pi);
    }
    bone_err_deg.push_back(worst);
    const auto& R = fp.torso_R_world;  // row-major; column y: where the performer faces
    facing.push_back(
        glm::dot(world["Hips"].second * dvec3(0, 0, 1), unity_from_world(dvec3(R[1], R[4], R[7]))));
  }
  EXPECT_EQ(posed, c.with_pose);
  ASSERT_GT(posed, 0u);
  // The wave performer (1.75 m) stands upright on the floor (Unity's y up, the floor at 0); the
  // received skeleton is the fitted one seen through M: its Hips where M p_world puts them, every limb
  // bone and the neck along the fitted bone, facing where the fitted torso faces.
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  EXPECT_GT(median(hips_y), 0.7);
  EXPECT_LT(median(hips_y), 1.2);
  EXPECT_GT(median(head_above), 0.5);
  EXPECT_GT(median(feet_y), -0.05);
  EXPECT_LT(median(feet_y), 0.3);
  ASSERT_GT(matched, posed / 2) << "bundles matched to their frame by T";
  RecordProperty("bone_err_deg_max",
                 std::to_string(*std::max_element(bone_err_deg.begin(), bone_err_deg.end())));
  EXPECT_LT(*std::max_element(hips_err_mm.begin(), hips_err_mm.end()), 0.1);  // float precision
  EXPECT_LT(*std::max_element(bone_err_deg.begin(), bone_err_deg.end()), 0.1);
  EXPECT_GT(median(facing), 0.8);
}

}  // namespace
}  // namespace vc::stream
