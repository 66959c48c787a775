// The failed-fit check from the hull (failure.hpp) on hw/sim's truth: the true trunk of every
// built-in motion is never flagged, on the true occupancy and on hulls carved from six cameras; a
// trunk left turned away from the body (the PCA's spine tilted about the neck) is; and a fitter on
// the true hulls of the built-in motions never re-acquires because of it.
#include "voxcap/fit/failure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "voxcap/fit/fitter.hpp"
#include "voxcap/fit/synthetic.hpp"

namespace vc::fit {
namespace {

using J = pipeline::PoseJoint;

std::array<Vec3, pipeline::kPoseJointCount> to_vec3(
    const std::array<cv::Vec3d, pipeline::kPoseJointCount>& t) {
  std::array<Vec3, pipeline::kPoseJointCount> out{};
  for (size_t j = 0; j < t.size(); ++j) out[j] = Vec3(t[j][0], t[j][1], t[j][2]);
  return out;
}

Vec3& joint(std::array<Vec3, pipeline::kPoseJointCount>& p, J j) {
  return p[static_cast<size_t>(j)];
}

// The trunk (pelvis centre and hip joints) turned by `deg` about the neck, about the axis `axis`
// (unit): a torso the PCA left tilted while the head stays where it is.
std::array<Vec3, pipeline::kPoseJointCount> trunk_turned(std::array<Vec3, pipeline::kPoseJointCount> p,
                                                         const Vec3& axis, double deg) {
  const double a = deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
  const Vec3 o = joint(p, J::neck);
  for (J j : {J::hips, J::l_hip, J::r_hip}) {
    const Vec3 v = joint(p, j) - o;  // Rodrigues
    joint(p, j) = o + v * c + glm::cross(axis, v) * s + axis * glm::dot(axis, v) * (1 - c);
  }
  return p;
}

const char* const kMotions[] = {"arms-close", "cross", "squat", "turn", "walk", "wave"};

// The true occupancy of `take`'s frame as the hull; `bits` is reused between calls.
void true_hull(const testing::SyntheticTake& take, int frame, HullBits* hull, std::vector<uint8_t>* bits) {
  take.scene().occupancy(take.grid(), frame, bits);
  hull->assign(*bits);
}

// The true pose's joints of `take`'s frame.
std::array<Vec3, pipeline::kPoseJointCount> true_joints(const testing::SyntheticTake& take, int frame) {
  return to_vec3(take.truth(frame));
}

TEST(TrunkInHull, TheTrueTrunkIsNeverOffTheTrueHull) {
  for (const char* motion : kMotions) {
    const testing::SyntheticTake take(motion, 0);
    HullBits hull(take.grid());
    std::vector<uint8_t> bits;
    int worst = 1 << 30, frames = 0;
    for (int frame = 0; frame < 600; frame += 3) {
      true_hull(take, frame, &hull, &bits);
      const TrunkInHull t = trunk_in_hull(hull, true_joints(take, frame));
      EXPECT_FALSE(trunk_off_hull(t))
          << motion << " frame " << frame << ": " << t.occupied << "/" << t.counted;
      worst = std::min(worst, t.occupied);
      ++frames;
    }
    std::printf("%-10s %d frames: fewest trunk points occupied %d of %d\n", motion, frames, worst,
                kTrunkAxisPoints + 2);
  }
}

// The rig's hull (six cameras, carved: phantom volumes, no holes) with the true trunk: never flagged.
TEST(TrunkInHull, TheTrueTrunkIsNeverOffACarvedHull) {
  for (const char* motion : {"squat", "turn"}) {
    const testing::SyntheticTake take(motion, 0);
    HullBits hull(take.grid());
    std::vector<cv::Mat> masks;
    for (int frame = 0; frame < 600; frame += 40) {
      hull.assign(testing::carved_hull(take.scene(), take.grid(), frame, &masks));
      const TrunkInHull t = trunk_in_hull(hull, true_joints(take, frame));
      EXPECT_FALSE(trunk_off_hull(t)) << motion << " frame " << frame;
    }
  }
}

// A torso left tilted about the neck 60 degrees or more forward or back, 90 or more sideways (hips
// 0.45 m and more from the body) is off the hull; one within 10 degrees of the truth is not.
TEST(TrunkInHull, ATrunkLeftTurnedAwayFromTheBodyIsOffTheHull) {
  for (const char* motion : kMotions) {
    const testing::SyntheticTake take(motion, 0);
    HullBits hull(take.grid());
    std::vector<uint8_t> bits;
    for (int frame = 0; frame < 600; frame += 50) {
      true_hull(take, frame, &hull, &bits);
      const auto truth = true_joints(take, frame);
      const Vec3 right =
          glm::normalize(truth[static_cast<size_t>(J::r_hip)] - truth[static_cast<size_t>(J::l_hip)]);
      const Vec3 up =
          glm::normalize(truth[static_cast<size_t>(J::neck)] - truth[static_cast<size_t>(J::hips)]);
      const Vec3 fwd = glm::normalize(glm::cross(up, right));
      for (const Vec3& axis : {right, -right, fwd, -fwd}) {
        // Sideways by 60 degrees the lower spine can lie along a spread arm: 90 and more there.
        const bool forward_or_back = std::abs(glm::dot(axis, right)) > 0.5;  // tilted about the right axis
        for (double deg : {60.0, 90.0, 120.0}) {
          if (deg < 90 && !forward_or_back) continue;
          const TrunkInHull t = trunk_in_hull(hull, trunk_turned(truth, axis, deg));
          EXPECT_TRUE(trunk_off_hull(t))
              << motion << " frame " << frame << " " << deg << " deg: " << t.occupied << "/" << t.counted;
        }
        EXPECT_FALSE(trunk_off_hull(trunk_in_hull(hull, trunk_turned(truth, axis, 10))))
            << motion << " frame " << frame;
      }
    }
  }
}

// A trunk outside the volume (the performer walked out of it) gives no verdict; an empty hull with the
// trunk inside the grid does.
TEST(TrunkInHull, OutsideTheVolumeIsNoVerdict) {
  const testing::SyntheticTake take("walk", 0);
  HullBits hull(take.grid());
  hull.assign(std::vector<uint8_t>(take.grid().bitset_bytes(), 0));
  auto p = true_joints(take, 0);
  EXPECT_TRUE(trunk_off_hull(trunk_in_hull(hull, p)));
  for (Vec3& v : p) v.x += 100;
  const TrunkInHull t = trunk_in_hull(hull, p);
  EXPECT_EQ(t.counted, 0);
  EXPECT_FALSE(trunk_off_hull(t));
}

// The fitter on the true hulls and noisy features of every built-in motion: never re-initialized
// after its initialization (no false alarm of the new check), the trunk never off the hull.
TEST(TrunkInHull, AGoodFitIsNeverReacquired) {
  for (const char* motion : kMotions) {
    testing::SyntheticTake take(motion, 17);
    Fitter fitter(take.grid(), {}, 60);
    HullBits hull(take.grid());
    int reinit = 0, off = 0, fitted = 0;
    for (int frame = 0; frame < 400; ++frame) {
      const pipeline::Frame f = take.frame(frame);
      const pipeline::Pose pose = fitter.fit(f);
      if (!pose.valid()) continue;
      ++fitted;
      reinit += pose.state == pipeline::PoseState::Reinitialized ? 1 : 0;
      std::array<Vec3, pipeline::kPoseJointCount> p{};
      for (size_t j = 0; j < p.size(); ++j)
        p[j] = Vec3(pose.p_world[j][0], pose.p_world[j][1], pose.p_world[j][2]);
      hull.decode(f.rle);
      off += trunk_off_hull(trunk_in_hull(hull, p)) ? 1 : 0;
    }
    EXPECT_GT(fitted, 300) << motion;
    EXPECT_EQ(reinit, 0) << motion;
    EXPECT_EQ(off, 0) << motion;
  }
}

}  // namespace
}  // namespace vc::fit
