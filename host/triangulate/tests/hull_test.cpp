// A 3D feature must lie on the body (host/triangulate/README.md, "On the body"): the merged hull as a
// lookup (HullMap: clearance outside it), and two-view ghost points outside it rejected.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "voxcap/rle.h"
#include "voxcap/sim/rig_layout.hpp"
#include "voxcap/triangulate/hull_map.hpp"
#include "voxcap/triangulate/triangulate.hpp"

namespace vc::triangulate {
namespace {

rig::VoxelGrid test_grid() {
  rig::VoxelGrid g;
  g.min_m = {-1.12, -1.12, 0};
  g.voxel_m = 0.0175;
  g.nx = g.ny = g.nz = 128;
  return g;
}

// A hull of balls (centre, radius) over `grid`, as the proto RLE.
std::vector<uint8_t> balls_rle(const rig::VoxelGrid& grid,
                               const std::vector<std::pair<cv::Vec3d, double>>& balls) {
  std::vector<uint8_t> bits(grid.bitset_bytes(), 0);
  for (int k = 0; k < grid.nz; ++k)
    for (int j = 0; j < grid.ny; ++j)
      for (int i = 0; i < grid.nx; ++i)
        for (const auto& [c, r] : balls)
          if (cv::norm(grid.center(i, j, k) - c) <= r) rig::hull_set(bits.data(), grid.index(i, j, k));
  std::vector<uint8_t> rle(vc_rle_max_encoded_size(grid.count()));
  size_t len = 0;
  EXPECT_EQ(vc_rle_encode(bits.data(), grid.count(), rle.data(), rle.size(), &len), 0);
  rle.resize(len);
  return rle;
}

// The map of a hull over g; the caller checks on().
HullMap map_of(const rig::VoxelGrid& g, const std::vector<uint8_t>& rle) {
  HullMap h;
  h.set(g, rle.data(), rle.size());
  return h;
}

TEST(HullMap, ClearanceIsTheDistanceToTheNearestOccupiedVoxel) {
  const rig::VoxelGrid g = test_grid();
  const cv::Vec3d c(0.1, -0.2, 1.0);
  const std::vector<uint8_t> rle = balls_rle(g, {{c, 0.10}});
  HullMap h;
  EXPECT_LT(h.clearance(c, 0.25), 0);  // off before set()
  ASSERT_TRUE(h.set(g, rle.data(), rle.size()));
  EXPECT_EQ(h.clearance(c, 0.25), 0);
  // Along +x: the ball's voxels reach to within half a voxel of r (voxel centres within r).
  for (double d : {0.05, 0.10, 0.20}) {
    const double got = h.clearance(c + cv::Vec3d(0.10 + d, 0, 0), 0.25);
    EXPECT_NEAR(got, d, g.voxel_m) << d;
  }
  EXPECT_GT(h.clearance(c + cv::Vec3d(0.10 + 0.5, 0, 0), 0.25), 0.25);  // beyond the cap: above it
  EXPECT_LT(h.clearance(cv::Vec3d(2.0, 0, 1), 0.25), 0);                // outside the grid: unknown
  // Malformed, wrong-sized or empty hulls leave the map off.
  std::vector<uint8_t> bad = rle;
  bad.back() = 0x80;
  EXPECT_FALSE(h.set(g, bad.data(), bad.size()));
  EXPECT_LT(h.clearance(c, 0.25), 0);
  rig::VoxelGrid small = g;
  small.nz = 64;
  EXPECT_FALSE(h.set(small, rle.data(), rle.size()));
  const std::vector<uint8_t> empty = balls_rle(g, {});
  EXPECT_FALSE(h.set(g, empty.data(), empty.size()));
}

// Three cameras see the hand; three others report one consistent wrong point (a shadow, a tracker on
// the background), exactly: a ghost that three views agree with, outside the body.
struct Ghost {
  rig::Calibration cal = sim::default_rig({});
  cv::Vec3d hand{0.35, 0.10, 1.25};
  cv::Vec3d ghost{-0.30, 0.55, 0.70};  // 0.9 m from the hand, in free space
  std::vector<View> views() const {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n(0, 1.0);
    std::vector<View> v;
    v.reserve(6);
    for (int c = 0; c < 6; ++c) {
      const bool on_ghost = c % 2 == 0;
      const double nx = on_ghost ? 0 : n(rng);
      const double ny = on_ghost ? 0 : n(rng);
      v.push_back({c,
                   cal.cameras[static_cast<size_t>(c)].project(on_ghost ? ghost : hand) + cv::Point2d(nx, ny),
                   0.9});
    }
    return v;
  }
  // The body: the hand and a torso, not the ghost.
  std::vector<uint8_t> hull(const rig::VoxelGrid& g) const {
    return balls_rle(g, {{hand, 0.06}, {cv::Vec3d(0, 0, 1.1), 0.25}});
  }
};

TEST(HullRule, ATwoViewGhostOutsideTheHullIsRejected) {
  const Ghost s;
  const rig::VoxelGrid g = test_grid();
  const HullMap h = map_of(g, s.hull(g));
  ASSERT_TRUE(h.on());
  ASSERT_GT(h.clearance(s.ghost, 0.25), 0.2);
  // Without the hull the exact ghost views win the 3-3 tie (smaller summed error): the wrong point.
  const PointResult without = triangulate_point(s.cal.cameras, s.views(), Options{});
  ASSERT_TRUE(without.ok);
  EXPECT_GT(cv::norm(without.p_world - s.hand), 0.5);
  // With it, no hypothesis off the body is considered: the hand.
  const PointResult with = triangulate_point(s.cal.cameras, s.views(), Options{}, &h);
  ASSERT_TRUE(with.ok);
  EXPECT_LT(cv::norm(with.p_world - s.hand), 0.04);  // three views, 1 px noise
  EXPECT_EQ(with.inliers, (std::vector<int>{1, 3, 5}));
}

TEST(HullRule, NoConfidentWrongHeadAndTheClearanceIsReported) {
  const Ghost s;
  const rig::VoxelGrid g = test_grid();
  const HullMap h = map_of(g, s.hull(g));
  ASSERT_TRUE(h.on());
  std::vector<CameraObservations> frame;
  for (const View& v : s.views()) {
    CameraObservations co;
    co.camera = v.camera;
    co.features[VC_FEATURE_HEAD] = {true, VC_FEATURE_TRACKING, v.uv_px, 0.9};
    frame.push_back(co);
  }
  const Options opt;
  // Rule off (no hull): the ghost, confident — a confident wrong answer.
  FeatureTriangulator off(s.cal.cameras, {0, 1}, opt);
  const pipeline::Feature3D a = off.process(frame)[VC_FEATURE_HEAD];
  ASSERT_EQ(a.state, pipeline::Feature3DState::Triangulated);
  EXPECT_GT(cv::norm(cv::Vec3d(a.p_world[0], a.p_world[1], a.p_world[2]) - s.hand), 0.5);
  EXPECT_GT(a.confidence, opt.confident);
  EXPECT_LT(a.hull_clearance_m, 0);  // no hull: not known
  // The rule switched off with the hull given: the same point, its clearance reported.
  FeatureTriangulator reported(s.cal.cameras, {0, 1}, opt);
  reported.set_hull_rule(false);
  const pipeline::Feature3D b = reported.process(frame, &h)[VC_FEATURE_HEAD];
  EXPECT_NEAR(b.p_world[0], a.p_world[0], 1e-9);
  EXPECT_NEAR(b.hull_clearance_m, kHullClearanceCapM, 1e-6);
  // The rule on: the same ghost (no hypothesis is rejected by default), but not confident.
  FeatureTriangulator on(s.cal.cameras, {0, 1}, opt);
  const pipeline::Feature3D c = on.process(frame, &h)[VC_FEATURE_HEAD];
  ASSERT_EQ(c.state, pipeline::Feature3DState::Triangulated);
  EXPECT_NEAR(c.p_world[0], a.p_world[0], 1e-9);
  EXPECT_LE(c.confidence, opt.confident);
  // The rule with rejection: the hand, inside the hull, confident again.
  FeatureTriangulator reject(s.cal.cameras, {0, 1}, opt);
  reject.set_hull_reject(true);
  const pipeline::Feature3D d = reject.process(frame, &h)[VC_FEATURE_HEAD];
  ASSERT_EQ(d.state, pipeline::Feature3DState::Triangulated);
  EXPECT_LT(cv::norm(cv::Vec3d(d.p_world[0], d.p_world[1], d.p_world[2]) - s.hand),
            0.04);  // three views, 1 px noise
  EXPECT_FLOAT_EQ(d.hull_clearance_m, 0);
}

TEST(HullRule, WithRejectionNoHypothesisOffTheBodySurvives) {
  // Every view sees one consistent point, outside the hull: no hypothesis survives, no point.
  const Ghost s;
  const rig::VoxelGrid g = test_grid();
  const HullMap h = map_of(g, balls_rle(g, {{cv::Vec3d(0, 0, 1.1), 0.25}}));
  ASSERT_TRUE(h.on());
  std::vector<View> v;
  v.reserve(6);
  for (int c = 0; c < 6; ++c) v.push_back({c, s.cal.cameras[static_cast<size_t>(c)].project(s.ghost), 0.9});
  EXPECT_TRUE(triangulate_point(s.cal.cameras, v, Options{}).ok);
  EXPECT_FALSE(triangulate_point(s.cal.cameras, v, Options{}, &h).ok);
}

}  // namespace
}  // namespace vc::triangulate
