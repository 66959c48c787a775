// The body's heading cue (heading.hpp) on hw/sim's truth: where the feet point on the true and the
// carved hull against the true heading over the built-in motions, independent of the feet's names;
// and the fitter turned round by it when the names follow a heading that was wrong from the start.
#include "voxcap/fit/heading.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "voxcap/body/joints.hpp"
#include "voxcap/fit/fitter.hpp"
#include "voxcap/fit/synthetic.hpp"

namespace vc::fit {
namespace {

using body::Joint;

// The true level forward (up x right) from the true shoulders and hips.
template <typename Joints>
Vec3 true_forward(const Joints& j) {
  auto P = [&j](Joint k) {
    const cv::Vec3d& v = j[static_cast<size_t>(k)];
    return Vec3(v[0], v[1], v[2]);
  };
  const Vec3 r = P(Joint::r_shoulder) - P(Joint::l_shoulder) + P(Joint::r_hip) - P(Joint::l_hip);
  return glm::normalize(Vec3(-r.y, r.x, 0));
}

FeatureSet features_of(const pipeline::Frame& f, std::array<bool, 5>* ok) {
  FeatureSet out{};
  *ok = {};
  for (const pipeline::Feature3D& ft : f.features3d) {
    out[ft.feature_id] = Vec3(ft.p_world[0], ft.p_world[1], ft.p_world[2]);
    (*ok)[ft.feature_id] = ft.state == pipeline::Feature3DState::Triangulated;
  }
  return out;
}

struct CueFigures {
  int frames = 0, valid = 0, wrong = 0;  // wrong: more than 90 degrees from the true forward
  std::vector<double> err_deg;
  double p95_deg = 0;
};

CueFigures measure(const std::string& motion, bool carved, int step) {
  testing::SyntheticTake take(motion, 5);
  HullBits hull(take.grid());
  std::vector<cv::Mat> masks;
  testing::FeatureNoise noise;
  noise.sigma_m = 0.015;
  CueFigures c;
  for (int frame = 0; frame < take.frames(); frame += step) {
    const pipeline::Frame f = carved ? take.carved_frame(frame, noise, &masks) : take.frame(frame, noise);
    EXPECT_TRUE(hull.decode(f.rle));
    std::array<bool, 5> ok{};
    const FeatureSet fs = features_of(f, &ok);
    const FeetCue cue = feet_forward(hull, fs, ok);
    ++c.frames;
    if (!cue.valid) continue;
    ++c.valid;
    const double d = std::clamp(glm::dot(cue.forward, true_forward(take.scene().joints(frame))), -1.0, 1.0);
    const double deg = std::acos(d) * 180 / M_PI;
    c.err_deg.push_back(deg);
    if (deg > 90) ++c.wrong;
  }
  std::sort(c.err_deg.begin(), c.err_deg.end());
  const double p50 = c.err_deg.empty() ? 0 : c.err_deg[c.err_deg.size() / 2];
  const double p95 = c.err_deg.empty() ? 0 : c.err_deg[c.err_deg.size() * 95 / 100];
  c.p95_deg = p95;
  std::printf("%-10s %-6s frames %3d valid %3d  error p50 %4.1f p95 %5.1f deg  wrong %d\n", motion.c_str(),
              carved ? "carved" : "true", c.frames, c.valid, p50, p95, c.wrong);
  return c;
}

// The feet on the hull point where the body faces: on the true hull of every built-in motion and on
// carved hulls (six cameras, 2 cm voxels, as the rig's 128^3), never more than 90 degrees off.
// Measured (1.5 cm feature noise): valid on 77-88 % of the frames (both feet on a foot's length
// ahead of their ankles, agreeing), error p50 7-9 and p95 19-24 degrees (the feet turn out a little
// and follow the hips, not the shoulders), never wrong.
TEST(FeetCue, PointsWhereTheBodyFaces) {
  for (const char* m : {"arms-close", "cross", "squat", "turn", "walk", "wave"}) {
    const CueFigures t = measure(m, false, 4);
    EXPECT_EQ(t.wrong, 0) << m;
    EXPECT_GE(t.valid, t.frames * 7 / 10) << m;
    EXPECT_LT(t.p95_deg, 35) << m;
  }
  for (const char* m : {"turn", "walk"}) {
    const CueFigures c = measure(m, true, 12);
    EXPECT_EQ(c.wrong, 0) << m;
    EXPECT_GE(c.valid, c.frames * 7 / 10) << m;
    EXPECT_LT(c.p95_deg, 35) << m;
  }
}

// The cue does not depend on which foot is called left: the same with the feet's names exchanged.
TEST(FeetCue, DoesNotDependOnTheFeetsNames) {
  testing::SyntheticTake take("walk", 7);
  HullBits hull(take.grid());
  int valid = 0;
  for (int frame = 0; frame < 200; frame += 10) {
    const pipeline::Frame f = take.frame(frame);
    ASSERT_TRUE(hull.decode(f.rle));
    std::array<bool, 5> ok{};
    FeatureSet fs = features_of(f, &ok);
    const FeetCue a = feet_forward(hull, fs, ok);
    std::swap(fs[3], fs[4]);
    const FeetCue b = feet_forward(hull, fs, ok);
    EXPECT_EQ(a.valid, b.valid) << frame;
    EXPECT_LT(glm::length(a.forward - b.forward), 1e-9) << frame;
    valid += a.valid;
  }
  EXPECT_GT(valid, 10);
}

// Two feet drawn as boxes on a 2 cm grid: 22 cm long along `dir` (from 6 cm behind the ankle), 8 cm
// wide, 8 cm tall, the sole `lift` metres above the floor; the ankles 10 cm above the sole.
struct TwoFeet {
  rig::VoxelGrid grid;
  HullBits hull;
  FeatureSet f{};
  std::array<bool, 5> ok{false, false, false, true, true};
  TwoFeet(const Vec3& dir, double lift_left, double lift_right) : grid(make_grid()), hull(grid) {
    std::vector<uint8_t> bits(grid.bitset_bytes(), 0);
    const Vec3 side(dir.y, -dir.x, 0);
    const double lifts[2] = {lift_left, lift_right};
    for (int k = 0; k < 2; ++k) {
      f[3 + static_cast<size_t>(k)] = Vec3(0, 0, lifts[k] + 0.10) + (k == 0 ? -0.12 : 0.12) * side;
      for (int i = 0; i < grid.nx; ++i)
        for (int j = 0; j < grid.ny; ++j)
          for (int z = 0; z < grid.nz; ++z) {
            const cv::Vec3d c = grid.center(i, j, z);
            const Vec3 d = Vec3(c[0], c[1], c[2]) - f[3 + static_cast<size_t>(k)];
            const double along = glm::dot(d, dir), across = glm::dot(d, side);
            if (along > -0.06 && along < 0.16 && std::abs(across) < 0.04 && d.z > -0.10 && d.z < -0.02) {
              const size_t idx = grid.index(i, j, z);
              bits[idx >> 3] = static_cast<uint8_t>(bits[idx >> 3] | (1u << (idx & 7)));
            }
          }
    }
    hull.assign(bits);
  }
  static rig::VoxelGrid make_grid() {
    rig::VoxelGrid g;
    g.min_m = {-0.5, -0.5, 0};
    g.voxel_m = 0.02;
    g.nx = g.ny = 50;
    g.nz = 60;
    return g;
  }
};

// A foot in the air (a kick: cmu/02_06's ankles at 0.66-0.81 m) points where the leg swings it, not
// where the body faces: no cue while an ankle is more than 35 cm above the floor. Without that rule the
// kicking foot pointing back beside the standing one gave a valid cue 180 degrees off, whose votes
// turned a correct torso round.
TEST(FeetCue, NoneWhileAFootIsInTheAir) {
  const Vec3 back(0, -1, 0);
  const TwoFeet standing(back, 0, 0);
  const FeetCue on_floor = feet_forward(standing.hull, standing.f, standing.ok);
  ASSERT_TRUE(on_floor.valid);
  EXPECT_GT(glm::dot(on_floor.forward, back), 0.95);
  const TwoFeet step(back, 0, 0.12);  // a walking step's swinging foot: still a cue
  EXPECT_TRUE(feet_forward(step.hull, step.f, step.ok).valid);
  const TwoFeet kick(back, 0, 0.6);
  EXPECT_FALSE(feet_forward(kick.hull, kick.f, kick.ok).valid);
  const TwoFeet jump(back, 0.4, 0.4);
  EXPECT_FALSE(feet_forward(jump.hull, jump.f, jump.ok).valid);
}

// Votes far apart are not "in a row": seven against, then more than kMaxGapFrames frames without a
// verdict, then one more against does not turn the torso round (cmu/02_06: seven votes of a kick at its
// frames 652-663, the eighth at 824 turned a correct torso round for 144 frames).
TEST(HeadingVote, VotesFarApartDoNotAddUp) {
  const Mat3 R(1.0);  // facing +y
  FeetCue behind;
  behind.valid = true;
  behind.forward = Vec3(0, -1, 0);
  const FeetCue none;
  HeadingVote v;
  for (int i = 0; i < HeadingVote::kFlipFrames - 1; ++i) EXPECT_FALSE(v.update(R, behind));
  for (int i = 0; i < HeadingVote::kMaxGapFrames; ++i) EXPECT_FALSE(v.update(R, none));
  EXPECT_EQ(v.against(), HeadingVote::kFlipFrames - 1);  // a short gap keeps the count
  EXPECT_FALSE(v.update(R, none));
  EXPECT_EQ(v.against(), 0);
  EXPECT_FALSE(v.update(R, behind));
  for (int i = 0; i < HeadingVote::kFlipFrames - 2; ++i) EXPECT_FALSE(v.update(R, behind));
  EXPECT_TRUE(v.update(R, behind));
}

TEST(HeadingVote, TurnsRoundAfterClearDisagreementOnly) {
  const Mat3 R(1.0);  // facing +y
  FeetCue behind;
  behind.valid = true;
  behind.forward = Vec3(0.2, -1, 0) / std::sqrt(1.04);
  FeetCue aside = behind;
  aside.forward = Vec3(1, -0.3, 0) / std::sqrt(1.09);  // 107 degrees: not clear
  FeetCue none;
  HeadingVote v;
  for (int i = 0; i < HeadingVote::kFlipFrames - 1; ++i) EXPECT_FALSE(v.update(R, behind)) << i;
  EXPECT_FALSE(v.update(R, none));   // a frame without the cue keeps the count
  EXPECT_FALSE(v.update(R, aside));  // one that is not clear starts it again
  for (int i = 0; i < HeadingVote::kFlipFrames - 1; ++i) EXPECT_FALSE(v.update(R, behind));
  EXPECT_TRUE(v.update(R, behind));
  const Mat3 T = turned_round(R);
  EXPECT_NEAR(glm::determinant(T), 1.0, 1e-12);
  EXPECT_LT(glm::dot(T[1], Vec3(0, 1, 0)), -0.99);
}

// Whether the fitted left shoulder lies nearer the true right shoulder than the true left one.
bool shoulders_swapped(const pipeline::Pose& pose,
                       const std::array<cv::Vec3d, pipeline::kPoseJointCount>& truth) {
  const cv::Vec3d l = testing::joint(pose, pipeline::PoseJoint::l_shoulder);
  return cv::norm(l - testing::joint(truth, pipeline::PoseJoint::r_shoulder)) <
         cv::norm(l - testing::joint(truth, pipeline::PoseJoint::l_shoulder));
}

// The circle the feet break: the triangulation names hands and feet by the fit's heading, and the fit
// was initialized from names that were the wrong way round. Without a cue from the body, the names
// follow the wrong heading and agree with it for the whole take (every frame's shoulders and hips
// swapped); with the feet on the hull it is turned round within a few frames, and stays right
// through the whole of `turn`.
TEST(Fitter, AHeadingWrongFromTheStartIsTurnedRoundByTheFeet) {
  testing::SyntheticTake take("turn", 17);
  Fitter fitter(take.grid(), {}, 60);
  const int n = take.frames();
  int first_fitted = -1, swapped_late = 0, swapped_early = 0;
  for (int frame = 0; frame < n; ++frame) {
    pipeline::Frame f = take.frame(frame);
    // Names: swapped while not initialized; then by the fit's right, as the triangulation does.
    auto name_pair = [&f](size_t a, const Vec3* right) {
      auto& A = f.features3d[a].p_world;
      auto& B = f.features3d[a + 1].p_world;
      const bool swap = right ? (B[0] - A[0]) * right->x + (B[1] - A[1]) * right->y < 0 : true;
      if (swap) std::swap(A, B);
    };
    const Vec3 right = fitter.layer1().R_torso_world[0];
    for (size_t pair : {size_t{1}, size_t{3}}) name_pair(pair, fitter.initialized() ? &right : nullptr);
    const pipeline::Pose pose = fitter.fit(f);
    if (!pose.valid()) continue;
    if (first_fitted < 0) first_fitted = frame;
    const bool swapped = shoulders_swapped(pose, take.truth(frame));
    (frame < first_fitted + 2 * HeadingVote::kFlipFrames ? swapped_early : swapped_late) += swapped;
  }
  std::printf("first fitted %d, swapped early %d, late %d of %d, turned round %llu\n", first_fitted,
              swapped_early, swapped_late, n, static_cast<unsigned long long>(fitter.heading_flips()));
  ASSERT_GE(first_fitted, 0);
  EXPECT_GT(swapped_early, 0);  // it did start the wrong way round
  // Turned round by the vote, before the failed frames would re-initialize it (15 frames).
  EXPECT_LE(swapped_early, HeadingVote::kFlipFrames + 1);
  EXPECT_EQ(swapped_late, 0);
  EXPECT_GE(fitter.heading_flips(), 1u);
}

// Re-initialization takes its heading from the feet on the hull, not from the names: walk, the hull
// empty for 20 frames (re-initialized, pending until a torso shows), the hands and feet named the wrong
// way round from then on. Re-acquired from the names, the torso would face backwards until the vote
// turned it round 8 frames later.
TEST(Fitter, ReacquiresItsHeadingFromTheFeetNotTheNames) {
  testing::SyntheticTake take("walk", 19);
  Fitter fitter(take.grid(), {}, 60);
  const int lost_from = 150, lost_to = 170;
  const std::vector<uint8_t> empty_rle =
      testing::encode_hull(take.grid(), std::vector<uint8_t>(take.grid().bitset_bytes(), 0));
  int reinit = 0, swapped = 0, scored = 0;
  for (int frame = 0; frame < lost_to + 20; ++frame) {
    pipeline::Frame f = take.frame(frame);
    if (frame >= lost_from) {
      std::swap(f.features3d[1].p_world, f.features3d[2].p_world);
      std::swap(f.features3d[3].p_world, f.features3d[4].p_world);
    }
    if (frame >= lost_from && frame < lost_to) f.rle = empty_rle;
    const pipeline::Pose pose = fitter.fit(f);
    reinit += pose.state == pipeline::PoseState::Reinitialized;
    if (frame < lost_to + 1 || !pose.valid()) continue;
    ++scored;
    swapped += shoulders_swapped(pose, take.truth(frame));
  }
  std::printf("re-initialized %d, shoulders swapped on %d of %d frames after the hull came back\n", reinit,
              swapped, scored);
  EXPECT_EQ(reinit, 1);
  EXPECT_GT(scored, 15);
  EXPECT_EQ(swapped, 0);
  EXPECT_EQ(fitter.heading_flips(), 0u);
}

// Without the feet on the hull the feet's names are no evidence against the torso's heading: the
// triangulation names them by this fit's own right, so they disagree with it only after a crossing
// (a crossing step, feet swapped by the tracker) or a re-acquisition that took the names' heading.
// wave with the feet named crosswise from 1 s in and the floor's slab (the feet) carved away, so the
// cue is never valid: the torso keeps its heading and is never re-initialized. When that disagreement
// failed the frame, it was re-initialized after reinit_after_frames and re-acquired from those names.
TEST(Fitter, FeetNamedAcrossTheTorsoDoNotFailItsHeadingWithoutTheCue) {
  testing::SyntheticTake take("wave", 23);
  Fitter fitter(take.grid(), {}, 60);
  const int crossed_from = take.lead_in() + 60, n = crossed_from + 120;
  const rig::VoxelGrid& grid = take.grid();
  HullBits hull(grid);
  std::vector<uint8_t> bits;
  int reinit = 0, swapped = 0, scored = 0, cues = 0;
  for (int frame = 0; frame < n; ++frame) {
    pipeline::Frame f = take.frame(frame);
    if (frame >= crossed_from) {
      std::swap(f.features3d[3].p_world, f.features3d[4].p_world);
      take.scene().occupancy(grid, frame, &bits);
      // The voxels below 16 cm (the feet and ankles): the first nx * ny * k bits.
      int k = 0;
      while (k < grid.nz && hull.centre(0, 0, k).z < 0.16) ++k;
      for (size_t idx = 0; idx < grid.index(0, 0, k); ++idx)
        bits[idx >> 3] = static_cast<uint8_t>(bits[idx >> 3] & ~(1u << (idx & 7)));
      f.rle = testing::encode_hull(grid, bits);
      hull.assign(bits);
      std::array<bool, 5> ok{};
      cues += feet_forward(hull, features_of(f, &ok), ok).valid;
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < crossed_from || !pose.valid()) continue;
    ++scored;
    reinit += pose.state == pipeline::PoseState::Reinitialized;
    swapped += shoulders_swapped(pose, take.truth(frame));
  }
  std::printf("feet named crosswise, no cue: %d frames, re-initialized %d, shoulders swapped %d\n", scored,
              reinit, swapped);
  EXPECT_EQ(cues, 0);  // the case this is about: no cue from the feet on the hull
  EXPECT_EQ(scored, n - crossed_from);
  EXPECT_EQ(reinit, 0);
  EXPECT_EQ(swapped, 0);
  EXPECT_EQ(fitter.heading_flips(), 0u);
}

}  // namespace
}  // namespace vc::fit
