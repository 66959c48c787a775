// Which leg a foot lies on, through the hull (sides.hpp), on hw/sim's truth: the true ankles against
// the true hip joints on the true occupancy and on hulls carved from six cameras, over the built-in
// motions, whatever the feet are called; and nothing said where the legs touch.
#include "voxcap/fit/sides.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "voxcap/fit/synthetic.hpp"

namespace vc::fit {
namespace {

using J = pipeline::PoseJoint;

Vec3 V(const cv::Vec3d& v) {
  return {v[0], v[1], v[2]};
}

struct SideFigures {
  int asked = 0, right = 0, wrong = 0;
};

// Every `step`-th frame of the motion, both true ankles asked about with the true hip joints as the
// roots and half the hip width as the margin (what the fitter asks).
SideFigures measure(const std::string& motion, bool carved, int step) {
  testing::SyntheticTake take(motion, 7);
  HullBits hull(take.grid());
  PairSides sides(take.grid());
  std::vector<cv::Mat> masks;
  SideFigures s;
  for (int frame = 0; frame < take.frames(); frame += step) {
    const pipeline::Frame f = carved ? take.carved_frame(frame, {}, &masks) : take.frame(frame);
    EXPECT_TRUE(hull.decode(f.rle));
    const auto t = take.truth(frame);
    const Vec3 hl = V(testing::joint(t, J::l_hip)), hr = V(testing::joint(t, J::r_hip));
    const Vec3 feet[2] = {V(testing::joint(t, J::l_ankle)), V(testing::joint(t, J::r_ankle))};
    if (!sides.compute(hull, hl, hr, feet, 2, 0.25)) continue;
    const double margin = 0.5 * glm::length(hr - hl);
    for (int side = 0; side < 2; ++side) {
      ++s.asked;
      const int said = sides.side(feet[side], margin);
      if (said == (side == 0 ? -1 : 1)) ++s.right;
      if (said == (side == 0 ? 1 : -1)) ++s.wrong;
    }
  }
  std::printf("%-10s %s: %4d feet asked, %4d on their own leg, %d on the other\n", motion.c_str(),
              carved ? "carved" : "true  ", s.asked, s.right, s.wrong);
  return s;
}

// A foot on its own leg through the hull, never on the other one; told on most frames of the motions
// whose feet are apart (walk, turn, wave's stance), and on the carved hull with its phantoms between
// the legs as well.
TEST(PairSides, AFootIsOnTheLegItsHipReachesThroughTheHull) {
  for (const char* motion : {"walk", "turn", "wave", "squat"}) {
    SCOPED_TRACE(motion);
    const SideFigures t = measure(motion, false, 3);
    EXPECT_EQ(t.wrong, 0);
    EXPECT_GT(t.right, 0.5 * t.asked);
  }
  for (const char* motion : {"walk", "turn"}) {
    SCOPED_TRACE(motion);
    const SideFigures c = measure(motion, true, 12);
    EXPECT_EQ(c.wrong, 0);
    EXPECT_GT(c.right, 0.5 * c.asked);
  }
}

// Legs apart (a box pelvis on two cylinders): each foot on its own side, a hip width further from the
// other hip through the hull. Legs held together touch all the way down: a foot is then about as
// near either hip through the hull, and nothing is said.
TEST(PairSides, LegsTogetherSayNothing) {
  rig::VoxelGrid grid;
  grid.min_m = {-0.5, -0.5, 0};
  grid.voxel_m = 0.02;
  grid.nx = grid.ny = 50;
  grid.nz = 55;
  HullBits hull(grid);
  auto legs = [&grid, &hull](double half_apart_m) {
    std::vector<uint8_t> bits(grid.bitset_bytes(), 0);
    for (int k = 0; k < grid.nz; ++k)
      for (int j = 0; j < grid.ny; ++j)
        for (int i = 0; i < grid.nx; ++i) {
          const cv::Vec3d c = grid.center(i, j, k);
          const bool pelvis = c[2] > 0.85 && c[2] < 1.05 && std::abs(c[0]) < 0.17 && std::abs(c[1]) < 0.1;
          bool leg = false;
          for (double x : {-half_apart_m, half_apart_m})
            leg = leg || (c[2] <= 0.9 && std::hypot(c[0] - x, c[1]) < 0.07);
          if (pelvis || leg) rig::hull_set(bits.data(), grid.index(i, j, k));
        }
    hull.assign(bits);
  };
  PairSides sides(grid);
  const Vec3 hl(-0.09, 0, 0.92), hr(0.09, 0, 0.92);
  const Vec3 feet[2] = {Vec3(-0.09, 0, 0.08), Vec3(0.09, 0, 0.08)};
  legs(0.09);  // apart: a gap of 4 cm between the legs
  ASSERT_TRUE(sides.compute(hull, hl, hr, feet, 2, 0.25));
  EXPECT_EQ(sides.side(feet[0], 0.09), -1);
  EXPECT_EQ(sides.side(feet[1], 0.09), 1);
  const double own = sides.distance_m(1, feet[1]), across = sides.distance_m(0, feet[1]);
  EXPECT_NEAR(own, 0.84, 0.05);
  EXPECT_NEAR(across - own, 0.18, 0.05);
  legs(0.03);  // together: the legs overlap all the way down
  const Vec3 together[2] = {Vec3(-0.03, 0, 0.08), Vec3(0.03, 0, 0.08)};
  ASSERT_TRUE(sides.compute(hull, hl, hr, together, 2, 0.25));
  EXPECT_EQ(sides.side(together[0], 0.09), 0);
  EXPECT_EQ(sides.side(together[1], 0.09), 0);
  // A root off the hull: nothing said.
  ASSERT_TRUE(sides.compute(hull, Vec3(-0.4, 0.4, 0.5), hr, together, 2, 0.25));
  EXPECT_EQ(sides.side(together[0], 0.09), 0);
}

}  // namespace
}  // namespace vc::fit
