// The fitter on hw/sim's truth: the true occupancy as the merged hull and noisy true features as the
// triangulated ones, over whole built-in motions. MPJPE per motion (printed; bounded by what was
// measured, with margin), no left/right swap through `turn`, no elbow or wrist inside the torso on
// `arms-close`, a hand's feature lost for 10 frames, re-initialization after a failed fit, and the
// "fit" stage in a pipeline.
#include "voxcap/fit/fitter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <vector>

#include <unistd.h>

#include "voxcap/body/testing/shared_clips.hpp"
#include "voxcap/fit/synthetic.hpp"
#include "voxcap/sim/body.hpp"

namespace vc::fit {
namespace {

using J = pipeline::PoseJoint;

using testing::joint;

struct MotionResult {
  double mpjpe_m = 0;
  std::array<double, pipeline::kPoseJointCount> per_joint_m{};
  int fitted = 0, frames = 0, swaps = 0, in_torso = 0;
  double worst_frame_m = 0;
};

// Fits `frames` frames of the motion (all of them from 0) and scores every fitted frame.
MotionResult run_motion(const std::string& motion, int frames, const testing::FeatureNoise& noise,
                        const config::FittingOptions& opt = {}, int score_from = 0, int score_to = 1 << 30) {
  testing::SyntheticTake take(motion, 11);
  Fitter fitter(take.grid(), opt, 60);
  MotionResult r;
  for (int frame = 0; frame < frames; ++frame) {
    const pipeline::Frame f = take.frame(frame, noise);
    const pipeline::Pose pose = fitter.fit(f);
    ++r.frames;
    if (!pose.valid() || frame < score_from || frame >= score_to) continue;
    ++r.fitted;
    const auto truth = take.truth(frame);
    const double e = testing::mpjpe(pose, truth);
    r.mpjpe_m += e;
    r.worst_frame_m = std::max(r.worst_frame_m, e);
    for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
      const auto& p = pose.p_world[static_cast<size_t>(j)];
      r.per_joint_m[static_cast<size_t>(j)] +=
          cv::norm(cv::Vec3d(p[0], p[1], p[2]) - truth[static_cast<size_t>(j)]);
    }
    // Left/right: each fitted shoulder and hip nearer its own true joint than the other side's.
    for (auto [l, rr] : {std::pair{J::l_shoulder, J::r_shoulder}, std::pair{J::l_hip, J::r_hip}}) {
      if (cv::norm(joint(pose, l) - joint(truth, l)) > cv::norm(joint(pose, l) - joint(truth, rr)) ||
          cv::norm(joint(pose, rr) - joint(truth, rr)) > cv::norm(joint(pose, rr) - joint(truth, l)))
        ++r.swaps;
    }
    // Elbows and wrists inside the true torso (chest, abdomen, pelvis primitives).
    const std::vector<sim::Primitive> prims = take.scene().primitives(frame);
    for (J j : {J::l_elbow, J::r_elbow, J::l_wrist, J::r_wrist})
      for (sim::Part part : {sim::Part::chest, sim::Part::abdomen, sim::Part::pelvis})
        if (prims[static_cast<size_t>(part)].contains(joint(pose, j))) {
          ++r.in_torso;
        }
  }
  if (r.fitted > 0) {
    r.mpjpe_m /= r.fitted;
    for (double& e : r.per_joint_m) e /= r.fitted;
  }
  std::printf("%-12s frames %4d fitted %4d  MPJPE %5.1f mm (worst frame %5.1f)  swaps %d  in-torso %d\n   ",
              motion.c_str(), r.frames, r.fitted, 1000 * r.mpjpe_m, 1000 * r.worst_frame_m, r.swaps,
              r.in_torso);
  for (int j = 0; j < pipeline::kPoseJointCount; ++j)
    std::printf(" %s %.0f", pipeline::pose_joint_name(j), 1000 * r.per_joint_m[static_cast<size_t>(j)]);
  std::printf("\n");
  return r;
}

int motion_frames(const std::string& name) {
  sim::SceneOptions so;
  so.motion.source = name;
  const sim::Motion m = sim::Motion::create(so.motion, so.body);
  return m.natural_frames();
}

TEST(Fitter, BuiltinMotionsOnTrueHullsAndNoisyFeatures) {
  // Measured (2 cm voxels, 1 cm feature noise), see host/fit/README.md; bounds with margin.
  // Measured 15.7 (arms-close) .. 18.0 (walk) mm; wrists and ankles are the features' own 16 mm.
  const std::map<std::string, double> bound_mm = {{"wave", 24}, {"walk", 24},       {"squat", 24},
                                                  {"turn", 24}, {"arms-close", 24}, {"cross", 24}};
  for (const auto& [motion, bound] : bound_mm) {
    SCOPED_TRACE(motion);
    const MotionResult r = run_motion(motion, motion_frames(motion), {});
    EXPECT_GE(r.fitted, r.frames - 12);  // all but the initialization frames
    EXPECT_LE(1000 * r.mpjpe_m, bound);
    EXPECT_EQ(r.swaps, 0);
    if (motion == "arms-close") EXPECT_EQ(r.in_torso, 0);
  }
}

// The rig's kind of hull: carved from the true silhouettes of the default six cameras (640x480), so
// with phantom volumes around the limbs; features 1.5 cm noisy.
TEST(Fitter, CarvedHullsOfSixCameras) {
  // By default the lead-in and 1.5 s of arms-close and walk and the whole of turn (the check:
  // no left/right swap through the whole turn; rendering six views is slow under the sanitizers);
  // VOXCAP_FIT_LONG=1: every built-in motion whole.
  const bool long_run = std::getenv("VOXCAP_FIT_LONG") != nullptr;
  const int frames = long_run ? 100000 : 180;
  const char* only = std::getenv("VOXCAP_FIT_MOTION");
  for (const char* motion : {"arms-close", "turn", "walk", "wave", "cross", "squat"}) {
    if (only && std::string(only) != motion) continue;
    if (!only && !long_run && std::string(motion) == "wave") break;  // the first three only
    SCOPED_TRACE(motion);
    testing::SyntheticTake take(motion, 21);
    Fitter fitter(take.grid(), {}, 60);
    testing::FeatureNoise noise;
    noise.sigma_m = 0.015;
    std::vector<cv::Mat> masks;
    double sum = 0;
    int fitted = 0, swaps = 0;
    std::array<double, pipeline::kPoseJointCount> per{};
    const int n = std::min(std::string(motion) == "turn" ? 100000 : frames, take.frames());
    for (int frame = 0; frame < n; ++frame) {
      const pipeline::Pose pose = fitter.fit(take.carved_frame(frame, noise, &masks));
      if (!pose.valid()) continue;
      const auto truth = take.truth(frame);
      sum += testing::mpjpe(pose, truth);
      for (int j = 0; j < pipeline::kPoseJointCount; ++j)
        per[static_cast<size_t>(j)] +=
            cv::norm(joint(pose, static_cast<J>(j)) - truth[static_cast<size_t>(j)]);
      if (cv::norm(joint(pose, J::l_shoulder) - joint(truth, J::l_shoulder)) >
          cv::norm(joint(pose, J::l_shoulder) - joint(truth, J::r_shoulder)))
        ++swaps;
      ++fitted;
    }
    std::printf("carved %-10s %d frames: MPJPE %.1f mm, swaps %d\n   ", motion, fitted, 1000 * sum / fitted,
                swaps);
    for (int j = 0; j < pipeline::kPoseJointCount; ++j)
      std::printf(" %s %.0f", pipeline::pose_joint_name(j), 1000 * per[static_cast<size_t>(j)] / fitted);
    std::printf("\n");
    // Measured on the default run (lead-in + 1.5 s): arms-close 23.9, walk 27.5 mm; the whole turn 29.3.
    const double bound_mm = std::string(motion) == "arms-close" ? 28 : 33;
    if (!long_run) EXPECT_LE(1000 * sum / fitted, bound_mm);
    EXPECT_EQ(swaps, 0);
  }
}

TEST(Fitter, AHandLostForTenFramesIsPredictedAndStaysClose) {
  // wave: the right hand waves first; its feature is lost for 10 frames in the middle of it.
  testing::SyntheticTake take("wave", 12);
  const int from = take.lead_in() + 90, to = from + 10;
  testing::FeatureNoise noise;
  noise.drop_feature = VC_FEATURE_RIGHT_HAND;
  noise.drop_from = from;
  noise.drop_to = to;
  Fitter fitter(take.grid(), {}, 60);
  double worst_wrist = 0, sum = 0;
  for (int frame = 0; frame < to + 5; ++frame) {
    const pipeline::Pose pose = fitter.fit(take.frame(frame, noise));
    if (frame < from || frame >= to) continue;
    EXPECT_EQ(pose.state, pipeline::PoseState::Predicted) << frame;
    const auto truth = take.truth(frame);
    worst_wrist = std::max(worst_wrist, cv::norm(joint(pose, J::r_wrist) - joint(truth, J::r_wrist)));
    sum += testing::mpjpe(pose, truth);
  }
  std::printf("right hand lost 10 frames: worst wrist error %.1f mm, MPJPE %.1f mm\n", 1000 * worst_wrist,
              100 * sum);
  // Measured 83 mm worst (the hand waving at ~1 m/s) and 17.9 mm MPJPE.
  EXPECT_LE(1000 * worst_wrist, 100);
  EXPECT_LE(100 * sum, 30);
}

// Frames out of trigger order (the assembler passes a complete frame on while an older one waits for a
// late node until its deadline): the late frame gets its pose, and every other frame's pose is exactly
// what it would have been had the late frame never come.
TEST(Fitter, AFrameArrivingAfterNewerOnesLeavesTheirHistoryAlone) {
  testing::SyntheticTake take("wave", 13);
  const int late = take.lead_in() + 60, frames = late + 20;
  testing::FeatureNoise noise;
  std::vector<pipeline::Frame> in;
  in.reserve(static_cast<size_t>(frames));
  for (int frame = 0; frame < frames; ++frame) in.push_back(take.frame(frame, noise));
  ASSERT_EQ(in[static_cast<size_t>(late)].seq + 1, in[static_cast<size_t>(late) + 1].seq)
      << "frames carry their seq";

  Fitter without(take.grid(), {}, 60), with(take.grid(), {}, 60);
  std::map<int, pipeline::Pose> a, b;
  for (int frame = 0; frame < frames; ++frame) {
    if (frame == late) continue;
    a[frame] = without.fit(in[static_cast<size_t>(frame)]);
    b[frame] = with.fit(in[static_cast<size_t>(frame)]);
    if (frame == late + 3) b[late] = with.fit(in[static_cast<size_t>(late)]);  // three frames late
  }
  EXPECT_EQ(with.late_frames(), 1u);
  EXPECT_EQ(without.late_frames(), 0u);
  for (const auto& [frame, pose] : a) {
    ASSERT_EQ(b[frame].state, pose.state) << frame;
    for (int j = 0; j < pipeline::kPoseJointCount; ++j)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(b[frame].p_world[static_cast<size_t>(j)][static_cast<size_t>(c)],
                  pose.p_world[static_cast<size_t>(j)][static_cast<size_t>(c)])
            << "frame " << frame << " joint " << pipeline::pose_joint_name(j);
  }
  ASSERT_TRUE(b[late].valid());
  const double e = testing::mpjpe(b[late], take.truth(late));
  std::printf("a frame fitted three frames late: MPJPE %.1f mm\n", 1000 * e);
  EXPECT_LT(1000 * e, 60);
}

// A foot feature off its leg (as a drifting or mislabelled colour track gives it): 25 cm to the
// performer's outside and 10 cm up for 30 frames of walk. The leg at the feature holds few samples in
// the hull; the leg fitted to the hull from it holds more and is taken: the ankle stays near the truth.
TEST(Fitter, AFootFeatureOffItsLegIsCheckedAgainstTheHull) {
  testing::SyntheticTake take("walk", 14);
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 30;
  double sum_fit = 0, sum_feature = 0, worst = 0;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    if (frame >= from) {
      const cv::Vec3d right = joint(truth, J::r_hip) - joint(truth, J::l_hip);
      const cv::Vec3d out = -0.25 * right / cv::norm(right) + cv::Vec3d(0, 0, 0.10);  // left foot: outside
      pipeline::Feature3D* ft = testing::feature(&f, VC_FEATURE_LEFT_FOOT);
      testing::set_position(ft, testing::position(*ft) + out);
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    const double e = cv::norm(joint(pose, J::l_ankle) - joint(truth, J::l_ankle));
    sum_fit += e;
    worst = std::max(worst, e);
    sum_feature +=
        cv::norm(testing::position(*testing::feature(&f, VC_FEATURE_LEFT_FOOT)) - joint(truth, J::l_ankle));
  }
  std::printf(
      "left foot feature 27 cm off for 30 frames: its error %.0f mm, the fitted ankle's %.0f mm (worst "
      "%.0f)\n",
      1000 * sum_feature / 30, 1000 * sum_fit / 30, 1000 * worst);
  EXPECT_GT(sum_feature / 30, 0.25);
  EXPECT_LT(sum_fit / 30, 0.5 * sum_feature / 30);
}

// A foot feature far off its leg (60 cm out to the side and 20 cm up for 30 frames of walk: a track
// on a shadow or on a point triangulated from the wrong blobs): the search about the feature finds
// nothing of the leg there, so the leg is fitted to the hull from its track's prediction too (README,
// "A foot feature off its leg"). Measured: the fitted ankle 39 mm (56 mm from the feature's search alone).
TEST(Fitter, AFootFeatureFarOffItsLegIsFittedToTheHullFromItsTrack) {
  testing::SyntheticTake take("walk", 15);
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 30;
  double sum_fit = 0, worst = 0;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    if (frame >= from) {
      const cv::Vec3d right = joint(truth, J::r_hip) - joint(truth, J::l_hip);
      const cv::Vec3d out = -0.6 * right / cv::norm(right) + cv::Vec3d(0, 0, 0.2);  // left foot: far out
      pipeline::Feature3D* ft = testing::feature(&f, VC_FEATURE_LEFT_FOOT);
      testing::set_position(ft, testing::position(*ft) + out);
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    const double e = cv::norm(joint(pose, J::l_ankle) - joint(truth, J::l_ankle));
    sum_fit += e;
    worst = std::max(worst, e);
  }
  std::printf("left foot feature 63 cm off for 30 frames: the fitted ankle %.0f mm (worst %.0f)\n",
              1000 * sum_fit / 30, 1000 * worst);
  EXPECT_LT(sum_fit / 30, 0.047);
}

// The triangulation names a pair the wrong way round for a while (hands and feet of walk, 50 frames
// from a stride with the feet apart): the fit takes the features crosswise from the first such frame
// to the last (the limbs' paths say so), counts each change, and the wrists and ankles stay on their
// own limbs.
TEST(Fitter, APairNamedTheWrongWayRoundIsTakenCrosswise) {
  testing::SyntheticTake take("walk", 15);
  config::FittingOptions opt;
  opt.follow_pair_swaps = true;  // off by default (README)
  Fitter fitter(take.grid(), opt, 60);
  auto feet_apart = [&take](int frame) {
    const auto t = take.truth(frame);
    return cv::norm(joint(t, J::l_ankle) - joint(t, J::r_ankle)) > 0.3;
  };
  int from = take.lead_in() + 60;
  while (!feet_apart(from)) ++from;
  int to = from + 50;
  while (!feet_apart(to)) ++to;
  double sum_swapped = 0, worst = 0;
  int swapped_pose_frames = 0;
  for (int frame = 0; frame < to + 20; ++frame) {
    pipeline::Frame f = take.frame(frame);
    if (frame >= from && frame < to)
      for (pipeline::Feature3D& ft : f.features3d) {
        // left <-> right of both pairs (ids 1/2 and 3/4)
        if (ft.feature_id == VC_FEATURE_LEFT_HAND || ft.feature_id == VC_FEATURE_LEFT_FOOT)
          ++ft.feature_id;
        else if (ft.feature_id == VC_FEATURE_RIGHT_HAND || ft.feature_id == VC_FEATURE_RIGHT_FOOT)
          --ft.feature_id;
      }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    const auto truth = take.truth(frame);
    for (J j : {J::l_wrist, J::r_wrist, J::l_ankle, J::r_ankle}) {
      const double e = cv::norm(joint(pose, j) - joint(truth, j));
      worst = std::max(worst, e);
      if (frame < to) sum_swapped += e / 4;
    }
    if (frame >= from && frame < to) swapped_pose_frames += fitter.pair_swapped(0) && fitter.pair_swapped(1);
  }
  std::printf(
      "hands and feet named the wrong way round for %d frames: wrists and ankles %.0f mm (worst %.0f), "
      "swaps hands %llu feet %llu\n",
      to - from, 1000 * sum_swapped / (to - from), 1000 * worst,
      static_cast<unsigned long long>(fitter.pair_swaps()[0]),
      static_cast<unsigned long long>(fitter.pair_swaps()[1]));
  EXPECT_EQ(swapped_pose_frames, to - from);
  EXPECT_EQ(fitter.pair_swaps()[0], 2u);  // taken crosswise at `from`, straight again at `to`
  EXPECT_EQ(fitter.pair_swaps()[1], 2u);
  EXPECT_FALSE(fitter.pair_swapped(0));
  EXPECT_FALSE(fitter.pair_swapped(1));
  EXPECT_LT(sum_swapped / (to - from), 0.03);
  EXPECT_LT(worst, 0.1);
}

// One hand's feature on the other hand (the right hand's track took the left hand) while the hands
// are apart, for 20 frames of wave: that feature is not believed (the limb predicted and fitted to
// the hull): the right wrist stays near its own hand.
TEST(Fitter, BothFeaturesOfAPairOnOnePointLoseTheWrongOne) {
  testing::SyntheticTake take("wave", 16);
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 20;
  double sum_fit = 0, sum_feature = 0;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    if (frame >= from) {
      const cv::Vec3d left = testing::position(*testing::feature(&f, VC_FEATURE_LEFT_HAND));
      pipeline::Feature3D* right = testing::feature(&f, VC_FEATURE_RIGHT_HAND);
      testing::set_position(right, left + cv::Vec3d(0.01, 0.01, 0.01));
      sum_feature += cv::norm(testing::position(*right) - joint(truth, J::r_wrist));
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    sum_fit += cv::norm(joint(pose, J::r_wrist) - joint(truth, J::r_wrist));
  }
  std::printf(
      "right hand's feature on the left hand for 20 frames: its error %.0f mm, the fitted wrist's %.0f mm\n",
      1000 * sum_feature / 20, 1000 * sum_fit / 20);
  EXPECT_GT(sum_feature / 20, 0.3);
  EXPECT_LT(sum_fit / 20, 0.1);
}

// The feet's names from the hull (README, "The feet's names from the hull"): walk, the feet's features
// edited on the frames of [from, from + 90) whose true ankles are more than 0.3 m apart (a stride), as
// the triangulation reports a wrong name it did not trust. Returns the fitted ankles' mean error there
// and the frames with a fitted ankle nearer the other side's true ankle than its own.
struct FeetFigures {
  int edited = 0, wrong_side = 0;
  double l_m = 0, r_m = 0;
};
// With `trusted`, the edited names are reported trusted: the hull does not judge them (the fit as it
// was without the rule).
FeetFigures run_feet_named_wrong(
    uint64_t seed, bool trusted, double apart_m,
    const std::function<void(pipeline::Frame*, const std::array<cv::Vec3d, pipeline::kPoseJointCount>&)>&
        edit) {
  testing::SyntheticTake take("walk", seed);
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 90;
  FeetFigures r;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    const bool apart = cv::norm(joint(truth, J::l_ankle) - joint(truth, J::r_ankle)) > apart_m;
    if (frame >= from && apart) {
      edit(&f, truth);
      if (trusted)
        for (pipeline::Feature3D& ft : f.features3d) ft.name_trusted = true;
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from || !apart) continue;
    EXPECT_TRUE(pose.valid()) << frame;
    ++r.edited;
    const double el = cv::norm(joint(pose, J::l_ankle) - joint(truth, J::l_ankle));
    const double er = cv::norm(joint(pose, J::r_ankle) - joint(truth, J::r_ankle));
    r.l_m += el;
    r.r_m += er;
    if (el > cv::norm(joint(pose, J::l_ankle) - joint(truth, J::r_ankle)) ||
        er > cv::norm(joint(pose, J::r_ankle) - joint(truth, J::l_ankle)))
      ++r.wrong_side;
  }
  if (r.edited > 0) r.l_m /= r.edited, r.r_m /= r.edited;
  std::printf("%s: %d frames edited: ankles %.0f / %.0f mm, %d with an ankle on the other side\n",
              trusted ? "names trusted (no rule)" : "names untrusted", r.edited, 1000 * r.l_m, 1000 * r.r_m,
              r.wrong_side);
  return r;
}

// (a) A lone foot point named as the wrong foot: the right foot not triangulated, the left foot's
// feature on the right ankle, its name untrusted. The hull puts it on the right leg; the left leg is
// fitted to the hull from its track. Without the rule the right leg is only predicted (its ankle
// 56 mm; with the rule 18 mm) and the left one fitted near the other foot.
TEST(Fitter, ALoneFootPointIsNamedByTheLegItIsOn) {
  const auto edit = [](pipeline::Frame* f, const auto&) {
    pipeline::Feature3D* l = testing::feature(f, VC_FEATURE_LEFT_FOOT);
    pipeline::Feature3D* rf = testing::feature(f, VC_FEATURE_RIGHT_FOOT);
    testing::set_position(l, testing::position(*rf));
    l->name_trusted = false;
    rf->state = pipeline::Feature3DState::TooFewViews;
    rf->confidence = 0;
  };
  const FeetFigures r = run_feet_named_wrong(21, false, 0.3, edit),
                    was = run_feet_named_wrong(21, true, 0.3, edit);
  ASSERT_GT(r.edited, 20);
  EXPECT_LE(r.wrong_side, 2);
  EXPECT_LT(r.r_m, 0.03);
  EXPECT_GT(was.r_m, 2 * r.r_m);
}

// (b) Both points on one foot, more than 6 cm apart (so not one point): the left foot's feature 8 cm
// up the right shank, untrusted, the right one where it belongs, on the frames with the feet more
// than 15 cm apart. The left one is on the right leg: not a left foot this frame (the left leg fitted
// to the hull from its track). Without the rule the left leg went to the right foot on 40 of 90
// frames (ankle 171 mm; with it 50 mm, none).
TEST(Fitter, TwoFootPointsOnOneLegLoseTheOneNamedForTheOther) {
  const auto edit = [](pipeline::Frame* f, const auto& truth) {
    pipeline::Feature3D* l = testing::feature(f, VC_FEATURE_LEFT_FOOT);
    const cv::Vec3d up = joint(truth, J::r_knee) - joint(truth, J::r_ankle);
    testing::set_position(l, joint(truth, J::r_ankle) + 0.08 * up / cv::norm(up));
    l->name_trusted = false;
  };
  const FeetFigures r = run_feet_named_wrong(22, false, 0.15, edit),
                    was = run_feet_named_wrong(22, true, 0.15, edit);
  ASSERT_GT(r.edited, 20);
  EXPECT_LE(r.wrong_side, 2);
  EXPECT_LT(r.r_m, 0.03);
  EXPECT_GT(was.wrong_side, 20);
  EXPECT_LT(r.l_m, 0.8 * was.l_m);
}

// (c) A pair named the wrong way round, both names untrusted: taken crosswise on each such frame (the
// hull says each point is on the other's leg), nothing kept after.
TEST(Fitter, FeetNamedTheWrongWayRoundAreTakenCrosswiseWhenTheHullAgrees) {
  const auto edit = [](pipeline::Frame* f, const auto&) {
    pipeline::Feature3D* l = testing::feature(f, VC_FEATURE_LEFT_FOOT);
    pipeline::Feature3D* rf = testing::feature(f, VC_FEATURE_RIGHT_FOOT);
    const cv::Vec3d pl = testing::position(*l);
    testing::set_position(l, testing::position(*rf));
    testing::set_position(rf, pl);
    l->name_trusted = rf->name_trusted = false;
  };
  const FeetFigures r = run_feet_named_wrong(23, false, 0.3, edit),
                    was = run_feet_named_wrong(23, true, 0.3, edit);
  ASSERT_GT(r.edited, 20);
  EXPECT_LE(r.wrong_side, 2);
  EXPECT_LT(r.l_m + r.r_m, 0.7 * (was.l_m + was.r_m));
}

// A hand feature in the middle of the chest (a track on the shirt) for 20 frames of arms-close: never
// taken for the wrist (the arm is predicted and fitted to the hull): no fitted wrist inside the true
// torso, and the wrist stays near its hand.
TEST(Fitter, AHandFeatureInsideTheTorsoIsNotAWrist) {
  testing::SyntheticTake take("arms-close", 17);
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 20;
  double sum_fit = 0;
  int in_torso = 0;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    if (frame >= from) {
      const cv::Vec3d chest = 0.5 * (joint(truth, J::neck) + joint(truth, J::hips));
      testing::set_position(testing::feature(&f, VC_FEATURE_RIGHT_HAND), chest);
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    sum_fit += cv::norm(joint(pose, J::r_wrist) - joint(truth, J::r_wrist));
    const std::vector<sim::Primitive> prims = take.scene().primitives(frame);
    for (sim::Part part : {sim::Part::chest, sim::Part::abdomen, sim::Part::pelvis})
      if (prims[static_cast<size_t>(part)].contains(joint(pose, J::r_wrist))) ++in_torso;
  }
  std::printf(
      "right hand's feature in the chest for 20 frames: the fitted wrist %.0f mm, %d frames in the torso\n",
      1000 * sum_fit / 20, in_torso);
  EXPECT_EQ(in_torso, 0);
  EXPECT_LT(sum_fit / 20, 0.1);
}

// A hand pressed against the body merges with it in the images, and its feature is pulled into the
// torso, though not deep enough to be taken as lost: the wrist is moved out of the torso.
TEST(Fitter, AWristFeaturePulledIntoTheTorsoIsMovedOut) {
  testing::SyntheticTake take("arms-close", 23);  // hands on the hips first
  Fitter fitter(take.grid(), {}, 60);
  const int from = take.lead_in() + 60, to = from + 20;
  double sum_fit = 0;
  int in_torso = 0, feature_in_torso = 0;
  for (int frame = 0; frame < to; ++frame) {
    pipeline::Frame f = take.frame(frame);
    const auto truth = take.truth(frame);
    const std::vector<sim::Primitive> prims = take.scene().primitives(frame);
    auto inside = [&prims](const cv::Vec3d& p) {
      for (sim::Part part : {sim::Part::chest, sim::Part::abdomen, sim::Part::pelvis})
        if (prims[static_cast<size_t>(part)].contains(p)) return true;
      return false;
    };
    if (frame >= from) {
      // The feature 9 cm from the true wrist toward the spine (level): inside the body.
      const cv::Vec3d w = joint(truth, J::r_wrist),
                      spine = 0.5 * (joint(truth, J::neck) + joint(truth, J::hips));
      cv::Vec3d in(spine[0] - w[0], spine[1] - w[1], 0);
      in *= 0.09 / cv::norm(in);
      testing::set_position(testing::feature(&f, VC_FEATURE_RIGHT_HAND), w + in);
      feature_in_torso += inside(w + in) ? 1 : 0;
    }
    const pipeline::Pose pose = fitter.fit(f);
    if (frame < from) continue;
    ASSERT_TRUE(pose.valid()) << frame;
    sum_fit += cv::norm(joint(pose, J::r_wrist) - joint(truth, J::r_wrist));
    in_torso += inside(joint(pose, J::r_wrist)) ? 1 : 0;
  }
  std::printf(
      "right hand's feature 9 cm into the body for 20 frames (%d of them inside): the fitted wrist %.0f mm, "
      "%d frames in the torso\n",
      feature_in_torso, 1000 * sum_fit / 20, in_torso);
  ASSERT_GE(feature_in_torso, 15);  // the test's premise: the features are inside the body
  EXPECT_EQ(in_torso, 0);
  EXPECT_LT(sum_fit / 20, 0.05);
}

// Squatting, the pelvis tilts forward with the trunk and the hip joints go back with it (README,
// "Legs"): on squat's true hulls, over the frames the true trunk leans forward by more than 20 degrees,
// the fitted hip joints and knees stay close to the truth (a level pelvis left them under the pelvis
// centre: hip joints 36, knees 26 mm; with the tilt 16 and 14).
TEST(Fitter, ASquattingPelvisTiltsWithTheTrunk) {
  testing::SyntheticTake take("squat", 31);
  Fitter fitter(take.grid(), {}, 60);
  const int frames = motion_frames("squat");
  double hips = 0, knees = 0;
  int n = 0;
  for (int frame = 0; frame < frames; ++frame) {
    const pipeline::Frame f = take.frame(frame);
    const pipeline::Pose pose = fitter.fit(f);
    const auto truth = take.truth(frame);
    const cv::Vec3d spine = joint(truth, J::neck) - joint(truth, J::hips);
    if (!pose.valid() || spine[2] > std::cos(20 * M_PI / 180) * cv::norm(spine)) continue;
    ++n;
    for (auto [hip, knee] : {std::pair{J::l_hip, J::l_knee}, std::pair{J::r_hip, J::r_knee}}) {
      hips += 0.5 * cv::norm(joint(pose, hip) - joint(truth, hip));
      knees += 0.5 * cv::norm(joint(pose, knee) - joint(truth, knee));
    }
  }
  std::printf("squat, %d frames with the trunk leaning over 20 degrees: hip joints %.0f mm, knees %.0f mm\n",
              n, 1000 * hips / std::max(n, 1), 1000 * knees / std::max(n, 1));
  ASSERT_GE(n, 30);  // the premise: the squat leans the trunk
  EXPECT_LT(hips / n, 0.025);
  EXPECT_LT(knees / n, 0.020);
}

// Walking, the arms swing bent ~20 degrees at the elbow, 6-9 mm short of full reach: the law of
// cosines cannot tell that bend from 1 cm of error in the arm's measured length, its shoulder or the
// wrist feature (on the emulated rig the arms were measured ~2.5 cm short and fitted straight, the
// elbows ~4 cm in front of the truth). With arms 2.5 cm shorter than the body's (body.toml) the hull
// decides the bend near full reach (README, "Near full reach").
TEST(Fitter, AnArmNearFullReachIsBentAsTheHullSays) {
  const std::filesystem::path toml = std::filesystem::temp_directory_path() /
                                     ("voxcap_fit_short_arms_" + std::to_string(::getpid()) + ".toml");
  {
    std::FILE* f = std::fopen(toml.c_str(), "w");
    ASSERT_NE(f, nullptr);
    const sim::BodyDescription t;
    std::fprintf(f, "upper_arm_m = %.4f\nforearm_m = %.4f\n", t.upper_arm_m - 0.013, t.forearm_m - 0.012);
    std::fclose(f);
  }
  testing::SyntheticTake take("walk", 33);
  config::FittingOptions opt;
  opt.body = toml;
  Fitter fitter(take.grid(), opt, 60);
  double elbows = 0;
  int n = 0;
  for (int frame = 0; frame < take.frames(); ++frame) {
    const pipeline::Pose pose = fitter.fit(take.frame(frame));
    if (frame < take.lead_in() || !pose.valid()) continue;
    const auto truth = take.truth(frame);
    elbows += 0.5 * (cv::norm(joint(pose, J::l_elbow) - joint(truth, J::l_elbow)) +
                     cv::norm(joint(pose, J::r_elbow) - joint(truth, J::r_elbow)));
    ++n;
  }
  std::filesystem::remove(toml);
  std::printf("walk, arms 2.5 cm short, %d frames: elbows %.0f mm\n", n, 1000 * elbows / n);
  ASSERT_GE(n, 300);
  EXPECT_LT(elbows / n, 0.030);
}

TEST(Fitter, ReinitializesAfterTheHullIsLostAndFitsAgain) {
  testing::SyntheticTake take("walk", 13);
  config::FittingOptions opt;
  opt.reinit_after_frames = 15;
  Fitter fitter(take.grid(), opt, 60);
  const int lost_from = 150, lost_to = 170;  // 20 frames without a body in the hull
  std::vector<uint8_t> empty_rle(vc_rle_max_encoded_size(take.grid().count()));
  {
    const std::vector<uint8_t> zero(take.grid().bitset_bytes(), 0);
    size_t len = 0;
    ASSERT_EQ(vc_rle_encode(zero.data(), take.grid().count(), empty_rle.data(), empty_rle.size(), &len), 0);
    empty_rle.resize(len);
  }
  int reinit = 0;
  uint32_t version_before = 0;
  BodyModel body_before;
  double sum_after = 0;
  int n_after = 0;
  // Re-initialization keeps the measured body: every length and radius as initialization measured it,
  // bit for bit, at the re-initialized frame and to the end.
  auto expect_same_body = [&body_before](const BodyModel& b, int frame) {
    const std::array<double BodyModel::*, 17> fields = {&BodyModel::neck_to_head_m,
                                                        &BodyModel::spine_m,
                                                        &BodyModel::shoulder_half_width_m,
                                                        &BodyModel::shoulder_drop_m,
                                                        &BodyModel::hip_half_width_m,
                                                        &BodyModel::pelvis_drop_m,
                                                        &BodyModel::upper_arm_m,
                                                        &BodyModel::forearm_m,
                                                        &BodyModel::thigh_m,
                                                        &BodyModel::shank_m,
                                                        &BodyModel::upper_arm_radius_m,
                                                        &BodyModel::forearm_radius_m,
                                                        &BodyModel::thigh_radius_m,
                                                        &BodyModel::shank_radius_m,
                                                        &BodyModel::torso_half_width_m,
                                                        &BodyModel::torso_half_depth_m,
                                                        &BodyModel::head_to_top_m};
    for (size_t i = 0; i < fields.size(); ++i)
      EXPECT_EQ(b.*fields[i], body_before.*fields[i]) << frame << " " << i;
  };
  for (int frame = 0; frame < 300; ++frame) {
    pipeline::Frame f = take.frame(frame);
    if (frame >= lost_from && frame < lost_to) f.rle = empty_rle;
    const pipeline::Pose pose = fitter.fit(f);
    if (frame == lost_from - 1) {
      version_before = pose.body_version;
      ASSERT_TRUE(fitter.initialized());
      body_before = fitter.body();
      // Measured, not the defaults: the test would not tell a reset to the defaults otherwise.
      EXPECT_NE(body_before.upper_arm_m, BodyModel{}.upper_arm_m);
      EXPECT_NE(body_before.thigh_m, BodyModel{}.thigh_m);
    }
    if (pose.state == pipeline::PoseState::Reinitialized) {
      ++reinit;
      EXPECT_EQ(frame, lost_from + opt.reinit_after_frames - 1);
      EXPECT_EQ(pose.body_version, version_before + 1);
    }
    if (frame >= lost_from + opt.reinit_after_frames - 1) {
      EXPECT_TRUE(fitter.initialized()) << frame;
      expect_same_body(fitter.body(), frame);
    }
    if (frame >= lost_from && frame < lost_to) EXPECT_LT(pose.confidence, 0.6) << frame;
    if (frame >= lost_to + 10) {
      EXPECT_EQ(pose.state, pipeline::PoseState::Fitted) << frame;
      sum_after += testing::mpjpe(pose, take.truth(frame));
      ++n_after;
    }
  }
  EXPECT_EQ(reinit, 1);
  std::printf("after the hull came back: MPJPE %.1f mm\n", 1000 * sum_after / n_after);
  EXPECT_LE(1000 * sum_after / n_after, 24);
}

// Only a pose fitted to its frame gives the triangulation the body's right: a re-initialized one took
// its heading from the features' names, the very thing the triangulation checks with it, and a
// predicted one (a limb without its feature) is where the heading went wrong on loaded live takes.
TEST(FitStage, PublishesTheTorsoRightOfFittedPosesOnly) {
  pipeline::BodyHeading h;
  pipeline::Pose p;
  p.torso_R_world = {0, -1, 0, 1, 0, 0, 0, 0, 1};  // right = world +y
  for (const pipeline::PoseState s :
       {pipeline::PoseState::None, pipeline::PoseState::Predicted, pipeline::PoseState::Reinitialized}) {
    p.state = s;
    publish_heading(p, 5, &h);
    EXPECT_FALSE(h.latest().has_value());
  }
  p.state = pipeline::PoseState::Fitted;
  publish_heading(p, 6, &h);
  ASSERT_TRUE(h.latest().has_value());
  EXPECT_EQ(h.latest()->seq, 6u);
  EXPECT_NEAR(h.latest()->right[1], 1.0, 1e-12);
  publish_heading(p, 7, nullptr);  // no heading to publish to: nothing
}

TEST(FitStage, FillsThePoseOfEveryFrameAndRefusesBadInput) {
  testing::SyntheticTake take("wave", 14);
  config::RigConfig rig;
  rig.grid = take.grid();
  FitStage stage;
  EXPECT_EQ(stage.name(), "fit");
  EXPECT_THROW(stage.configure(pipeline::StageContext{}), std::invalid_argument);
  pipeline::StageContext ctx;
  ctx.rig = &rig;
  stage.configure(ctx);
  int fitted = 0;
  for (int frame = 0; frame < 40; ++frame) {
    pipeline::Frame f = take.frame(frame);
    stage.process(f);
    if (frame < rig.fitting.init_frames - 1) {
      EXPECT_EQ(f.pose.state, pipeline::PoseState::None) << frame;  // initialization frames
    } else {
      EXPECT_EQ(f.pose.state, pipeline::PoseState::Fitted) << frame;
      EXPECT_EQ(f.pose.body_version, 1u);
      EXPECT_GT(f.pose.confidence, 0.7f);
      EXPECT_GT(f.pose.t_fitted_ns, 0u);
      EXPECT_LE(testing::mpjpe(f.pose, take.truth(frame)), 0.03);
      // The init pose faces -y: the performer's right is world -x, up is z (row-major R).
      EXPECT_LT(f.pose.torso_R_world[0], -0.95);
      EXPECT_LT(f.pose.torso_R_world[4], -0.95);
      EXPECT_GT(f.pose.torso_R_world[8], 0.95);
      // ... published for the triangulation of the next frames (its check of left and right).
      const auto h = ctx.body_heading->latest();
      EXPECT_TRUE(h && h->seq == f.seq && h->right[0] < -0.95) << frame;
      ++fitted;
    }
  }
  EXPECT_EQ(fitted, 40 - rig.fitting.init_frames + 1);
  // A malformed hull or none: no pose, no exception, and the fitter goes on.
  pipeline::Frame bad = take.frame(40);
  bad.rle.resize(bad.rle.size() / 2);
  stage.process(bad);
  EXPECT_EQ(bad.pose.state, pipeline::PoseState::None);
  pipeline::Frame unmerged = take.frame(41);
  unmerged.merged = false;
  stage.process(unmerged);
  EXPECT_EQ(unmerged.pose.state, pipeline::PoseState::None);
  pipeline::Frame good = take.frame(42);
  stage.process(good);
  EXPECT_EQ(good.pose.state, pipeline::PoseState::Fitted);
  // Features that are no numbers, or ids out of range, are ignored.
  good.features3d[0].p_world[0] = std::nan("");
  good.features3d.push_back(good.features3d[1]);
  good.features3d.back().feature_id = 77;
  stage.process(good);
  EXPECT_EQ(good.pose.state, pipeline::PoseState::Predicted);
  for (const auto& p : good.pose.p_world)
    for (double v : p) EXPECT_TRUE(std::isfinite(v));
}

// Issue #12: clips scored against the joints their own convention names "Hips" and "Neck" (CMU's root
// 10 cm above its hip joints, its lowerneck 5 cm below its shoulders) charged the convention to the
// fit. hw/sim defines a clip's pelvis centre and neck base as the standard body does, from its hip and
// shoulder joints. Every shared clip's held init pose (1 s) on true hulls with 1 cm-noisy features:
// measured MPJPE 21.3-36.5 mm (mean 24.9), hips mean 28, neck mean 31 mm; with the file's own joints
// 33.3-39.3 mm (mean 36.4), hips 59, neck 84 mm (walk: 16, 13, 14 mm).
TEST(Fitter, EveryClipsInitPoseOnTrueHullsScoresTheStandardJoints) {
  const std::vector<std::filesystem::path> clips = body::testing::shared_bvh_clips();
  ASSERT_FALSE(clips.empty()) << body::testing::no_clips_message();
  double mpjpe = 0, hips = 0, neck = 0;
  for (const std::filesystem::path& clip : clips) {
    SCOPED_TRACE(clip.string());
    const MotionResult r = run_motion(clip.string(), 60, {});  // the held init pose (1 s)
    ASSERT_GT(r.fitted, 45);
    EXPECT_LE(1000 * r.mpjpe_m, 38);
    mpjpe += r.mpjpe_m;
    hips += r.per_joint_m[static_cast<size_t>(J::hips)];
    neck += r.per_joint_m[static_cast<size_t>(J::neck)];
  }
  const double n = static_cast<double>(clips.size());
  EXPECT_LE(1000 * mpjpe / n, 28);
  EXPECT_LE(1000 * hips / n, 35);
  EXPECT_LE(1000 * neck / n, 35);
}
}  // namespace
}  // namespace vc::fit
