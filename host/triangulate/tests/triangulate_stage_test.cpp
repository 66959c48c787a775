// The triangulation stage in a pipeline: FEATURES per node camera (as the assembler puts them in the
// frame) mapped to the rig's cameras through the rig config, triangulated into Frame::features3d.
#include "voxcap/triangulate/triangulate_stage.hpp"

#include <gtest/gtest.h>

#include <mutex>
#include <random>

#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/rle.h"
#include "voxcap/triangulate/synthetic.hpp"

namespace vc::triangulate {
namespace {

// Three nodes of two cameras, node numbers 4, 5, 6 in reverse camera order, so that node camera
// index and rig camera index differ: node 4 drives cam1 and cam0 (front), node 5 cam3, cam2, ...
config::RigConfig make_rig(const rig::Calibration& cal) {
  config::RigConfig rig;
  rig.calibration = cal;
  for (int n = 0; n < 3; ++n) {
    config::NodeConfig node;
    node.id = "node" + std::to_string(4 + n);
    node.number = static_cast<uint16_t>(4 + n);
    node.cameras = {"cam" + std::to_string(2 * n + 1), "cam" + std::to_string(2 * n)};
    node.role = n == 0 ? config::NodeRole::Front : config::NodeRole::Side;
    rig.nodes.push_back(node);
  }
  return rig;
}

pipeline::FramePtr to_frame(uint64_t seq, const std::vector<CameraObservations>& obs) {
  auto f = std::make_shared<pipeline::Frame>();
  f->seq = seq;
  for (const CameraObservations& co : obs) {
    const uint16_t node = static_cast<uint16_t>(4 + co.camera / 2);
    const uint16_t cam = static_cast<uint16_t>(1 - co.camera % 2);  // reverse order, as in make_rig
    pipeline::NodePart* part = nullptr;
    for (pipeline::NodePart& p : f->nodes)
      if (p.node_id == node) part = &p;
    if (!part) {
      f->nodes.push_back({});
      part = &f->nodes.back();
      part->node_id = node;
    }
    vc_features m{};
    m.camera = cam;
    for (uint16_t i = 0; i < 5; ++i) {
      const Observation& o = co.features[i];
      if (!o.present) continue;
      vc_feature& w = m.features[m.feature_count++];
      w.feature_id = i;
      w.state = o.state;
      w.u = static_cast<float>(o.uv_px.x);
      w.v = static_cast<float>(o.uv_px.y);
      w.confidence = static_cast<float>(o.confidence);
    }
    part->features.push_back(m);
  }
  return f;
}

class Collect : public pipeline::Stage {
 public:
  std::string name() const override { return "collect"; }
  void process(pipeline::Frame& f) override {
    std::lock_guard<std::mutex> g(mu);
    frames.push_back(f);
  }
  std::mutex mu;
  std::vector<pipeline::Frame> frames;
};

TEST(TriangulateStage, MapsNodeCamerasToTheRigAndFillsTheFrame) {
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.rig.cameras = 6;
  const sim::Scene scene(so);
  const config::RigConfig rig = make_rig(scene.calibration());
  EXPECT_EQ(rig_camera_of(rig, 4, 0), 1);
  EXPECT_EQ(rig_camera_of(rig, 6, 1), 4);
  EXPECT_EQ(rig_camera_of(rig, 6, 2), -1);
  EXPECT_EQ(rig_camera_of(rig, 9, 0), -1);
  EXPECT_EQ(front_cameras(rig), (std::vector<int>{0, 1}));

  pipeline::StageContext ctx;
  ctx.rig = &rig;
  pipeline::Pipeline p(ctx);
  p.then(std::make_unique<TriangulateStage>(), {8, pipeline::Overflow::Block});
  Collect& out = p.tap(std::make_unique<Collect>(), {8, pipeline::Overflow::Block});
  p.start();
  std::mt19937_64 rng(5);
  testing::Noise noise;
  const int frames = 90;
  for (int f = 0; f < frames; ++f)
    p.push(to_frame(static_cast<uint64_t>(f), testing::observe(scene, f * 2, noise, rng)));
  // A hostile frame: an unknown node, a camera index out of range, a feature id out of range.
  auto bad = to_frame(frames, testing::observe(scene, 0, noise, rng));
  bad->nodes.push_back({});
  bad->nodes.back().node_id = 99;
  bad->nodes.back().features.push_back(bad->nodes[0].features[0]);
  bad->nodes[0].features[0].camera = 7;
  bad->nodes[1].features[0].features[0].feature_id = 12;
  p.push(bad);
  p.stop();

  ASSERT_EQ(out.frames.size(), static_cast<size_t>(frames + 1));
  int good = 0;
  for (int f = 0; f < frames; ++f) {
    const pipeline::Frame& fr = out.frames[static_cast<size_t>(f)];
    ASSERT_TRUE(fr.triangulated);
    ASSERT_EQ(fr.features3d.size(), 5u);
    for (int id = 0; id < 5; ++id) {
      const pipeline::Feature3D& r = fr.features3d[static_cast<size_t>(id)];
      EXPECT_EQ(r.feature_id, id);
      if (r.state != pipeline::Feature3DState::Triangulated) continue;
      const cv::Vec3d p3(r.p_world[0], r.p_world[1], r.p_world[2]);
      EXPECT_LT(cv::norm(p3 - testing::truth(scene, f * 2, id)), 0.03) << "frame " << f << " feature " << id;
      EXPECT_GE(r.views.size(), 2u);
      EXPECT_TRUE(std::is_sorted(r.views.begin(), r.views.end()));
      for (uint16_t v : r.views) EXPECT_LT(v, 6);
      ++good;
    }
  }
  EXPECT_GT(good, frames * 4);
  EXPECT_TRUE(out.frames.back().triangulated);
  EXPECT_EQ(p.report().stages.size(), 2u);
}

TEST(TriangulateStage, ReportsTheClearanceOutsideTheMergedHullWhenTheFrameHasOne) {
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.rig.cameras = 6;
  const sim::Scene scene(so);
  config::RigConfig rig = make_rig(scene.calibration());
  rig.grid = rig::VoxelGrid::covering(so.rig.volume_min_m, so.rig.volume_max_m, 0.0175);
  TriangulateStage stage;
  pipeline::StageContext ctx;
  ctx.rig = &rig;
  stage.configure(ctx);
  std::mt19937_64 rng(9);
  const testing::Noise noise;
  std::vector<uint8_t> bits, rle(vc_rle_max_encoded_size(rig.grid.count()));
  int reported = 0;
  for (int f = 0; f < 40; ++f) {
    pipeline::FramePtr fr = to_frame(static_cast<uint64_t>(f), testing::observe(scene, f * 3, noise, rng));
    // The body's own occupancy as the merged hull; every third frame none (an older session), every
    // fifth a malformed one (hostile input): the rule is off there, said by a clearance of -1.
    scene.occupancy(rig.grid, f * 3, &bits);
    size_t len = 0;
    ASSERT_EQ(vc_rle_encode(bits.data(), rig.grid.count(), rle.data(), rle.size(), &len), 0);
    fr->rle.assign(rle.begin(), rle.begin() + static_cast<std::ptrdiff_t>(len));
    fr->voxel_count = rig.grid.count();
    fr->merged = f % 3 != 0;
    if (f % 5 == 0) fr->rle.resize(len / 2);
    stage.process(*fr);
    const bool hull = fr->merged && f % 5 != 0;
    for (const pipeline::Feature3D& r : fr->features3d) {
      if (r.state != pipeline::Feature3DState::Triangulated || !hull) {
        EXPECT_EQ(r.hull_clearance_m, -1) << f;
        continue;
      }
      // The true points (1 px noise) lie on the body: within a voxel of its occupancy.
      EXPECT_GE(r.hull_clearance_m, 0) << f;
      EXPECT_LE(r.hull_clearance_m, 0.0175) << f << " feature " << r.feature_id;
      ++reported;
    }
  }
  EXPECT_GT(reported, 40 * 2);
}

TEST(TriangulateStage, ConfigureRejectsARigWithoutCameras) {
  config::RigConfig rig;
  pipeline::StageContext ctx;
  TriangulateStage s;
  EXPECT_THROW(s.configure(ctx), std::invalid_argument);
  ctx.rig = &rig;
  EXPECT_THROW(s.configure(ctx), std::invalid_argument);
}

TEST(TriangulationConfig, ReadFromItsOwnBlockWithDefaultsAndChecks) {
  const std::string base = R"(
calibration = "rig.yaml"
[grid]
min_m = [-1.0, -1.0, 0.0]
voxel_m = 0.1
nx = 20
ny = 20
nz = 20
[[nodes]]
id = "node0"
cameras = ["cam0", "cam1"]
role = "front"
[trigger.udp]
targets = ["127.0.0.1:7601"]
)";
  config::LoadOptions lo;
  lo.load_calibration = false;
  const config::RigConfig d = config::parse_rig_config(base, "/tmp/rig.toml", lo);
  EXPECT_TRUE(d.triangulation.enabled);
  EXPECT_DOUBLE_EQ(d.triangulation.inlier_px, 6.0);
  EXPECT_DOUBLE_EQ(d.triangulation.confident, 0.5);
  const config::RigConfig c = config::parse_rig_config(
      base +
          "[triangulation]\nenabled = false\ninlier_px = 4.5\nconfident = 0.6\nrefine_iterations = 3\n"
          "min_confidence = 0.3\npredicted_weight = 0.25\nswap_ratio = 0.4\nidentity_gap_frames = 12\n",
      "/tmp/rig.toml", lo);
  EXPECT_FALSE(c.triangulation.enabled);
  EXPECT_DOUBLE_EQ(c.triangulation.inlier_px, 4.5);
  EXPECT_DOUBLE_EQ(c.triangulation.confident, 0.6);
  EXPECT_EQ(c.triangulation.refine_iterations, 3);
  EXPECT_DOUBLE_EQ(c.triangulation.min_confidence, 0.3);
  EXPECT_DOUBLE_EQ(c.triangulation.predicted_weight, 0.25);
  EXPECT_DOUBLE_EQ(c.triangulation.swap_ratio, 0.4);
  EXPECT_EQ(c.triangulation.identity_gap_frames, 12);
  try {
    config::parse_rig_config(base + "[triangulation]\nconfident = 1.5\n", "/tmp/rig.toml", lo);
    ADD_FAILURE() << "no error";
  } catch (const config::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("triangulation"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("confident"), std::string::npos) << e.what();
  }
  EXPECT_THROW(config::parse_rig_config(base + "[triangulation]\ninlier = 3.0\n", "/tmp/rig.toml", lo),
               config::ConfigError);
}

}  // namespace
}  // namespace vc::triangulate
