// CameraTracker on the virtual rig (hw/sim): 2D error against the true head centre, wrists and ankles
// while visible, losses and recovery on motions where parts occlude each other, and hostile input.
// Masks are the edge's own (edge/core subtraction + clean-up), as on a node.
#include <gtest/gtest.h>

#include <cmath>

#include "track_eval.hpp"

namespace vc::track {
namespace {

using eval::EvalOptions;
using eval::EvalResult;
using eval::FeatureScore;

FeatureScore pooled(const EvalResult& r) {
  FeatureScore all;
  all.errors = r.all_errors();
  for (const auto& f : r.features) {
    all.visible += f.visible;
    all.visible_untracked += f.visible_untracked;
    all.far_tracking += f.far_tracking;
    all.unrecovered += f.unrecovered;
  }
  return all;
}

void print(const char* name, const EvalResult& r) {
  const FeatureScore all = pooled(r);
  std::printf("%s: p50 %.2f px p95 %.2f px, visible %d untracked %d, >25 px %d, unrecovered %d\n", name,
              all.pct(0.5), all.pct(0.95), all.visible, all.visible_untracked, all.far_tracking,
              all.unrecovered);
}

TEST(CameraTracker, WaveOnSixCamerasFollowsHeadWristsAndAnklesFromTrueSeeds) {
  EvalOptions o;
  o.motion = "wave";
  o.frames = 150;
  const EvalResult r = eval::evaluate(o);
  print("wave", r);
  const FeatureScore all = pooled(r);
  ASSERT_GT(all.errors.size(), 3000u);
  EXPECT_LE(all.pct(0.5), 4.0);
  EXPECT_LE(all.pct(0.95), 20.0);
  EXPECT_LE(r.features[0].pct(0.5), 1.5);  // the head centre
  EXPECT_LE(r.features[0].pct(0.95), 3.0);
  // Visible and tracked nearly always, and hardly ever far from the truth.
  EXPECT_LE(all.visible_untracked, all.visible / 10);
  EXPECT_LE(all.far_tracking, int(all.errors.size()) / 50);
  EXPECT_EQ(all.unrecovered, 0);
  // The reported point is the joint, not the skin blob: the wrists and ankles within a few pixels, and
  // no systematic offset along the forearm or the shank (the blob's centre sits 3-5 px beyond the
  // wrist and 5-10 px in front of and below the ankle; measured here: p50 1.4-1.7 px, mean offset
  // along the limb -1.5..-0.7 px).
  for (int f = 1; f < kFeatures; ++f) {
    SCOPED_TRACE(f);
    const auto fs = static_cast<std::size_t>(f);
    EXPECT_LE(r.features[fs].pct(0.5), 2.5);
    ASSERT_GT(r.bias2d[fs].n, 300);
    EXPECT_LE(std::abs(r.bias2d[fs].mean(&eval::LimbBias::along)), 2.5);
    EXPECT_LE(std::abs(r.bias2d[fs].mean(&eval::LimbBias::across)), 2.5);
  }
}

TEST(CameraTracker, CrossingForearmsLoseAHandAndGetItBack) {
  EvalOptions o;
  o.motion = "cross";
  o.first_frame = 0;
  o.frames = 200;
  const EvalResult r = eval::evaluate(o);
  print("cross", r);
  const int losses = r.features[1].losses + r.features[2].losses;
  EXPECT_GT(losses, 0);  // the forearms do cross in some views
  int recovered = 0;
  for (int f : {1, 2}) recovered += int(r.features[static_cast<std::size_t>(f)].recover.size());
  EXPECT_GE(recovered, losses - 2);  // at most one loss per hand still open when the clip ends
  // Issue #11 wants every loss back within 10 frames of the part being visible again; today up to two
  // losses on this clip (of 6 cameras) stay open longer (README, figures).
  EXPECT_LE(pooled(r).unrecovered, 2);
}

// A drawn figure whose sleeves and trouser legs end in a round cap centred on the joint, as the
// clothes of a limb do, over skin hands and feet that start under the cap: the reported point is the
// cap's centre (the wrist, the ankle) whichever way the limb points, not the skin blob's centre.
TEST(CameraTrackerJoint, TheWristAndTheAnkleAreTheCentresOfTheClothesEndsInAnyDirection) {
  const cv::Vec3b skin(215, 165, 135), shirt(40, 60, 170), trousers(60, 60, 80);
  cv::Mat3b rgb(240, 320, cv::Vec3b(90, 90, 90));
  cv::Mat1b mask(240, 320, uchar(0));
  auto line = [&](cv::Point2f a, cv::Point2f b, int thickness, const cv::Vec3b& c) {
    cv::line(rgb, a, b, cv::Scalar(c[0], c[1], c[2]), thickness);
    cv::line(mask, a, b, 255, thickness);
  };
  auto disc = [&](cv::Point2f a, int r, const cv::Vec3b& c) {
    cv::circle(rgb, a, r, cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
    cv::circle(mask, a, r, 255, cv::FILLED);
  };
  rgb(cv::Rect(135, 60, 50, 100)).setTo(shirt);
  mask(cv::Rect(135, 60, 50, 100)).setTo(255);
  disc({160, 40}, 15, skin);  // head
  // Limbs: {from (shoulder, hip), joint, the skin part's direction from the joint}; the skin first,
  // the clothes over it with a cap of the limb's radius on the joint.
  struct Limb {
    cv::Point2f from, joint, dir;
    int radius;
    cv::Vec3b cloth;
  };
  const std::array<Limb, 4> limbs = {{{{182, 70}, {236, 112}, {0.8f, 0.6f}, 6, shirt},      // left hand
                                      {{138, 70}, {80, 64}, {-1.0f, 0.0f}, 6, shirt},       // right hand
                                      {{172, 158}, {178, 212}, {0.6f, 0.8f}, 7, trousers},  // left foot
                                      {{148, 158}, {140, 212}, {0.0f, 1.0f}, 7, trousers}}};
  for (const Limb& l : limbs) {
    line(l.joint, l.joint + 20.0f * l.dir, 10, skin);
    line(l.from, l.joint, 2 * l.radius, l.cloth);
    disc(l.joint, l.radius, l.cloth);
  }
  const auto seeder = [&](const cv::Mat1b&, Seeds* s, std::string*) {
    *s = Seeds{};
    (*s)[0] = {true, {160, 40}};
    for (std::size_t k = 0; k < 4; ++k) (*s)[k + 1] = {true, limbs[k].joint + 15.0f * limbs[k].dir};
    return true;
  };
  CameraTracker t({}, seeder);
  FrameReport rep;
  for (int i = 0; i < 12; ++i) t.process(rgb, mask, &rep);
  ASSERT_TRUE(t.initialised());
  EXPECT_EQ(rep[0].state, FeatureState::tracking);
  EXPECT_LE(cv::norm(rep[0].uv - cv::Point2f(160, 40)), 1.5) << rep[0].uv;
  for (std::size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(k + 1);
    const FeatureReport& r = rep[k + 1];
    EXPECT_EQ(r.state, FeatureState::tracking);
    // Within 1.5 px of the joint (the blob's centre is ~15 px from it; the point extrapolated from the
    // blob before this estimate was 2.1-3.2 px off here).
    EXPECT_LE(cv::norm(r.uv - limbs[k].joint), 1.5) << r.uv << " vs " << limbs[k].joint;
  }
}

// Feet standing together in a front view: the edge's mask keeps the shadowed floor between them, of a
// skin-like hue on a wooden floor, and each foot's joint estimate reaches the other foot's pixels; they
// must not pull an ankle towards the middle of the pair (before: both ankles reported between the
// feet, 11-12 px off, in a third of the front views' frames; feet p95 11-12 px on wave).
TEST(CameraTrackerJoint, FeetStandingTogetherKeepTheirOwnAnkles) {
  EvalOptions o;
  o.motion = "wave";  // the init pose and a wave: the feet stand together throughout
  o.frames = 60;
  o.truth_seeds = false;  // edge/segment's seeds, as on a node
  const EvalResult r = eval::evaluate(o);
  for (int f : {3, 4}) {
    SCOPED_TRACE(f);
    const FeatureScore& s = r.features[static_cast<std::size_t>(f)];
    ASSERT_GT(s.errors.size(), 200u);
    std::printf("foot %d: p50 %.2f px p95 %.2f px\n", f, s.pct(0.5), s.pct(0.95));
    EXPECT_LE(s.pct(0.5), 2.5);
    EXPECT_LE(s.pct(0.95), 8.0);
  }
}

struct Hostile : ::testing::Test {
  cv::Mat3b rgb = cv::Mat3b(120, 160, cv::Vec3b(200, 150, 120));
  cv::Mat1b mask = cv::Mat1b(120, 160, uchar(0));
  // A performer-like blob: skin head, blue body, skin hands and feet, seeds where they are.
  void draw() {
    rgb.setTo(cv::Vec3b(90, 90, 90));
    mask.setTo(0);
    auto part = [&](const cv::Rect& r, const cv::Vec3b& c) {
      rgb(r).setTo(c);
      mask(r).setTo(255);
    };
    part({60, 30, 40, 60}, {40, 60, 170});    // torso
    part({70, 10, 20, 20}, {215, 165, 135});  // head
    part({20, 40, 40, 8}, {40, 60, 170});     // arms
    part({100, 40, 40, 8}, {40, 60, 170});
    part({10, 38, 10, 12}, {215, 165, 135});  // hands
    part({140, 38, 10, 12}, {215, 165, 135});
    part({62, 90, 14, 20}, {60, 60, 80});  // legs
    part({84, 90, 14, 20}, {60, 60, 80});
    part({60, 110, 16, 6}, {215, 165, 135});  // feet
    part({84, 110, 16, 6}, {215, 165, 135});
  }
  static bool seeds(const cv::Mat1b& m, Seeds* s, std::string* why) {
    if (cv::countNonZero(m) == 0) {
      *why = "empty";
      return false;
    }
    *s = Seeds{};
    (*s)[0] = {true, {80, 20}};
    (*s)[1] = {true, {145, 44}};
    (*s)[2] = {true, {15, 44}};
    (*s)[3] = {true, {92, 113}};
    // (*s)[4]: the right foot is never found
    return true;
  }
};

TEST_F(Hostile, EmptySilhouettesNeverStartTrackingAndSayWhy) {
  CameraTracker t({}, seeds);
  FrameReport rep;
  for (int i = 0; i < 10; ++i) t.process(rgb, mask, &rep);
  EXPECT_FALSE(t.initialised());
  EXPECT_EQ(t.last_seed_failure(), "empty");
  for (const auto& r : rep) EXPECT_EQ(r.state, FeatureState::not_visible);
}

TEST_F(Hostile, AFeatureNeverSeenStaysNotVisibleAndAnEmptyMaskLosesTheRest) {
  draw();
  TrackerOptions o;
  o.init_frames = 3;
  CameraTracker t(o, seeds);
  FrameReport rep;
  for (int i = 0; i < 5; ++i) t.process(rgb, mask, &rep);
  ASSERT_TRUE(t.initialised());
  for (int f = 0; f < 4; ++f) {
    EXPECT_EQ(rep[static_cast<std::size_t>(f)].state, FeatureState::tracking) << f;
    EXPECT_GT(rep[static_cast<std::size_t>(f)].confidence, 0.5f) << f;
  }
  EXPECT_EQ(rep[4].state, FeatureState::not_visible);
  EXPECT_NEAR(rep[0].uv.x, 80, 2);  // the head's centre (it has no neck here)
  EXPECT_NEAR(rep[0].uv.y, 20, 2);
  const cv::Point2f head = rep[0].uv;
  const cv::Mat1b empty(mask.size(), uchar(0));
  // Freshly lost: predicted (constant velocity: standing still here) with a low confidence for
  // predict_frames frames, then lost.
  t.process(rgb, empty, &rep);
  for (int f = 0; f < 4; ++f) {
    EXPECT_EQ(rep[static_cast<std::size_t>(f)].state, FeatureState::predicted) << f;
    EXPECT_GT(rep[static_cast<std::size_t>(f)].confidence, 0.0f);
    EXPECT_LE(rep[static_cast<std::size_t>(f)].confidence, o.predicted_confidence);
  }
  EXPECT_LT(cv::norm(rep[0].uv - head), 1.0);
  for (int i = 0; i < o.predict_frames; ++i) t.process(rgb, empty, &rep);
  for (int f = 0; f < 4; ++f) {
    EXPECT_EQ(rep[static_cast<std::size_t>(f)].state, FeatureState::lost) << f;
    EXPECT_EQ(rep[static_cast<std::size_t>(f)].confidence, 0.0f);
  }
  EXPECT_EQ(rep[0].uv, head);  // lost: the last known position
  EXPECT_EQ(rep[4].state, FeatureState::not_visible);
  // The silhouette comes back: every lost feature is re-acquired, with a confidence that starts low.
  t.process(rgb, mask, &rep);
  for (int f = 0; f < 4; ++f) {
    EXPECT_EQ(rep[static_cast<std::size_t>(f)].state, FeatureState::tracking) << f;
    EXPECT_LT(rep[static_cast<std::size_t>(f)].confidence, 0.5f) << f;
  }
  EXPECT_EQ(t.reacquisitions(), 4u);
  for (int i = 0; i < o.recover_frames + 1; ++i) t.process(rgb, mask, &rep);
  EXPECT_GT(rep[1].confidence, 0.9f);
}

// Two hands on one arm-bar move past each other at constant speed (forearms crossing, hands swinging
// past each other in a side view): the same colour, one blob while they overlap. While the windows
// converge the hands are reported predicted (low confidence, on their own paths), and once they part
// each feature follows its own hand, not the other one.
TEST(CameraTrackerAmbiguity, HandsPassingEachOtherKeepTheirIdentity) {
  cv::Mat3b rgb(120, 200, cv::Vec3b(90, 90, 90));
  cv::Mat1b mask(120, 200, uchar(0));
  const int speed = 3, w = 10, h = 12;
  auto hand_x = [&](int f, int i) { return f == 1 ? 30 + speed * i : 160 - speed * i; };
  auto draw = [&](int i) {
    rgb.setTo(cv::Vec3b(90, 90, 90));
    mask.setTo(0);
    rgb(cv::Rect(10, 50, 180, 8)).setTo(cv::Vec3b(40, 60, 170));  // the arms' cloth
    mask(cv::Rect(10, 50, 180, 8)).setTo(255);
    for (int f : {1, 2}) {
      const cv::Rect r(hand_x(f, i), 48, w, h);
      rgb(r).setTo(cv::Vec3b(215, 165, 135));
      mask(r).setTo(255);
    }
  };
  int frame = 0;
  Seeder seeder = [&](const cv::Mat1b&, Seeds* s, std::string*) {
    *s = Seeds{};
    (*s)[1] = {true, {float(hand_x(1, frame)) + 0.5f * float(w), 54}};
    (*s)[2] = {true, {float(hand_x(2, frame)) + 0.5f * float(w), 54}};
    return true;
  };
  TrackerOptions o;
  o.init_frames = 1;
  CameraTracker t(o, seeder);
  FrameReport rep;
  int predicted = 0;
  for (frame = 0; frame <= 40; ++frame) {
    draw(frame);
    t.process(rgb, mask, &rep);
    ASSERT_TRUE(t.initialised());
    const double gap = std::abs(hand_x(1, frame) - hand_x(2, frame));
    for (int f : {1, 2}) {
      const FeatureReport& r = rep[static_cast<std::size_t>(f)];
      const cv::Point2f truth(float(hand_x(f, frame)) + 0.5f * float(w), 54);
      if (r.state == FeatureState::predicted) {
        predicted++;
        EXPECT_LE(r.confidence, o.predicted_confidence);
        EXPECT_LT(cv::norm(r.uv - truth), 6.0) << "frame " << frame << ": on its own path";
      } else if (r.state == FeatureState::tracking && r.confidence > 0.5f) {
        // Confident: on its own hand.
        EXPECT_LT(cv::norm(r.uv - truth), 6.0) << "frame " << frame << " feature " << f;
      }
      if (gap < w) {
        EXPECT_LE(r.confidence, 0.5f) << "frame " << frame << ": overlapping hands are never confident";
      }
    }
  }
  EXPECT_GT(predicted, 0);
  // Parted for good: each feature tracks its own hand.
  for (int f : {1, 2}) {
    const FeatureReport& r = rep[static_cast<std::size_t>(f)];
    EXPECT_EQ(r.state, FeatureState::tracking) << f;
    EXPECT_LT(std::abs(r.uv.x - (float(hand_x(f, 40)) + 0.5f * float(w))), 4.0f) << f;
  }
}

// Two hands that arrive at each other and then lie on top of each other for longer than the ambiguity
// lasts (ambiguous_max_frames) are decided on the spot, where either assignment fits as well as the
// other: no tracker can tell which hand leaves upwards. Until something settles it, neither window
// may be reported confidently (the host would triangulate a confident wrong 2D point half the time).
TEST(CameraTrackerAmbiguity, HandsThatLayOnEachOtherAreNotConfidentAfterwards) {
  cv::Mat3b rgb(120, 200, cv::Vec3b(90, 90, 90));
  cv::Mat1b mask(120, 200, uchar(0));
  const int w = 10, h = 12, meet = 20, together = 35, apart_speed = 2;
  // Hand f's top-left corner at frame i: closing in horizontally, on top of each other, then one
  // leaves upwards and the other downwards from the same place.
  auto hand = [&](int f, int i) {
    if (i < meet) return cv::Point(f == 1 ? 40 + 3 * i : 140 - 3 * i, 48);
    if (i < together) return cv::Point(90, 48);
    const int dy = apart_speed * (i - together);
    return cv::Point(90, f == 1 ? 48 - dy : 48 + dy);
  };
  auto draw = [&](int i) {
    rgb.setTo(cv::Vec3b(90, 90, 90));
    mask.setTo(0);
    rgb(cv::Rect(10, 50, 180, 8)).setTo(cv::Vec3b(40, 60, 170));  // the arms' cloth
    mask(cv::Rect(10, 50, 180, 8)).setTo(255);
    for (int f : {1, 2}) {
      const cv::Rect r(hand(f, i), cv::Size(w, h));
      rgb(r).setTo(cv::Vec3b(215, 165, 135));
      mask(r).setTo(255);
    }
  };
  int frame = 0;
  Seeder seeder = [&](const cv::Mat1b&, Seeds* s, std::string*) {
    *s = Seeds{};
    for (int f : {1, 2})
      (*s)[static_cast<std::size_t>(f)] = {true, cv::Point2f(hand(f, frame)) + cv::Point2f(0.5f * w, 6)};
    return true;
  };
  TrackerOptions o;
  o.init_frames = 1;
  CameraTracker t(o, seeder);
  FrameReport rep;
  int tracked_after = 0;
  for (frame = 0; frame <= together + 20; ++frame) {
    draw(frame);
    t.process(rgb, mask, &rep);
    ASSERT_TRUE(t.initialised());
    if (frame < together + 3) continue;  // apart by more than a hand's height from here on
    for (int f : {1, 2}) {
      const FeatureReport& r = rep[static_cast<std::size_t>(f)];
      if (r.state != FeatureState::tracking) continue;
      tracked_after++;
      EXPECT_LE(r.confidence, 0.5f) << "frame " << frame << " feature " << f
                                    << ": which hand it holds cannot be known";
    }
  }
  EXPECT_GT(tracked_after, 10);  // both windows go on tracking a hand, only without confidence
}

// The feet together seen from the side, one behind the other: one skin blob at init, on which both
// seeds fall; one foot takes it, the other has no window. When the performer steps, the feet part:
// the second foot joins from the blob beside its sibling's window, and the two are named by the
// seeder's rule (the performer's left foot on the image's right), each window on its own foot. Before:
// the second foot was never tracked in such a view and the lone window kept whichever foot it
// happened to (the front foot or the back one, step after step).
TEST(CameraTrackerJoin, AFootSeededOnItsSiblingsBlobJoinsWhenTheFeetPart) {
  cv::Mat3b rgb(120, 200, cv::Vec3b(90, 90, 90));
  cv::Mat1b mask(120, 200, uchar(0));
  const int still = 80, w = 16, start = 6, speed = 2;
  // The moving foot's left edge at frame i: behind the still one (4 px apart, one blob) until
  // `start`, then stepping towards the image's right.
  auto moving_x = [&](int i) { return still + 4 + std::max(0, i - start) * speed; };
  auto draw = [&](int i) {
    rgb.setTo(cv::Vec3b(90, 90, 90));
    mask.setTo(0);
    for (int x : {still, moving_x(i)}) {
      rgb(cv::Rect(x + 2, 70, w - 4, 40)).setTo(cv::Vec3b(60, 60, 80));  // the trouser leg
      mask(cv::Rect(x + 2, 70, w - 4, 40)).setTo(255);
    }
    for (int x : {still, moving_x(i)}) {
      rgb(cv::Rect(x, 110, w, 6)).setTo(cv::Vec3b(215, 165, 135));  // the foot
      mask(cv::Rect(x, 110, w, 6)).setTo(255);
    }
  };
  Seeder seeder = [&](const cv::Mat1b&, Seeds* s, std::string*) {
    *s = Seeds{};
    (*s)[3] = {true, {float(still + 10), 112}};  // both on the one blob
    (*s)[4] = {true, {float(still + 10), 112}};
    return true;
  };
  TrackerOptions o;
  o.init_frames = 1;
  CameraTracker t(o, seeder);
  FrameReport rep;
  int frame = 0;
  for (; frame < start; ++frame) {
    draw(frame);
    t.process(rgb, mask, &rep);
    ASSERT_TRUE(t.initialised());
  }
  EXPECT_EQ(rep[4].state, FeatureState::not_visible);  // one blob: one window
  bool joined = false;
  for (; frame < start + 30; ++frame) {
    draw(frame);
    t.process(rgb, mask, &rep);
    if (!joined && rep[4].state == FeatureState::tracking) {
      joined = true;
      // Both names may just have changed: neither is confident yet.
      EXPECT_LT(rep[3].confidence, 0.5f) << "frame " << frame;
      EXPECT_LT(rep[4].confidence, 0.5f) << "frame " << frame;
    }
  }
  ASSERT_TRUE(joined);
  const float moving_centre = float(moving_x(frame - 1)) + 0.5f * float(w);
  const float still_centre = float(still) + 0.5f * float(w);
  for (int f : {3, 4}) EXPECT_EQ(rep[static_cast<std::size_t>(f)].state, FeatureState::tracking) << f;
  // The performer's left foot (3) is the one on the image's right, here the moving one.
  EXPECT_LT(std::abs(rep[3].uv.x - moving_centre), 6.0f) << rep[3].uv.x;
  EXPECT_LT(std::abs(rep[4].uv.x - still_centre), 6.0f) << rep[4].uv.x;
  EXPECT_GT(rep[3].confidence, 0.5f);
  EXPECT_GT(rep[4].confidence, 0.5f);
}

TEST_F(Hostile, ANewImageSizeOrAMismatchedMaskStartsAgainWithoutCrashing) {
  draw();
  TrackerOptions o;
  o.init_frames = 1;
  CameraTracker t(o, seeds);
  FrameReport rep;
  t.process(rgb, mask, &rep);
  ASSERT_TRUE(t.initialised());
  t.process(rgb, cv::Mat1b(10, 10, uchar(255)), &rep);  // mask of another size: nothing reported
  for (const auto& r : rep) EXPECT_EQ(r.state, FeatureState::not_visible);
  cv::Mat3b small;
  cv::resize(rgb, small, {80, 60});
  cv::Mat1b small_mask(60, 80, uchar(0));
  t.process(small, small_mask, &rep);
  EXPECT_FALSE(t.initialised());
}

TEST(TrackerOptions, InvalidOptionsAreRefusedWithAReason) {
  TrackerOptions o;
  o.init_frames = 0;
  EXPECT_THROW(CameraTracker{o}, std::invalid_argument);
  std::string why;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_EQ(why, "init_frames must be 1..1000");
}

TEST(ExtremitySeeds, FindTheFiveFeaturesOfTheInitPoseOnTheTrueFrontSilhouette) {
  sim::SceneOptions so;
  so.motion.source = "wave";
  sim::Scene scene(so);
  cv::Mat rgb, sil;
  scene.render(0, 0, rgb, &sil);
  Seeds s;
  std::string why;
  ASSERT_TRUE(extremity_seeds(sil, &s, &why)) << why;
  const auto truth = eval::truth_features(scene, 0, 0);
  const double height = cv::boundingRect(sil).height;
  for (int f = 0; f < kFeatures; ++f) {
    ASSERT_TRUE(s[static_cast<std::size_t>(f)].found) << f;
    // On the same feature (left/right by image side), within a hand's length (0.11 of the height) of its
    // true joint: a seed only has to put the learning disk on the feature's skin.
    EXPECT_LT(
        cv::norm(cv::Point2d(s[static_cast<std::size_t>(f)].point) - truth[static_cast<std::size_t>(f)].uv),
        0.1 * height)
        << f;
  }
  // The default seeder (edge/segment's GVD terminals) on the same silhouette: the five joints.
  Seeds g;
  ASSERT_TRUE(segment_seeds(sil, &g, &why)) << why;
  for (int f = 0; f < kFeatures; ++f) {
    ASSERT_TRUE(g[static_cast<std::size_t>(f)].found) << f;
    EXPECT_LT(
        cv::norm(cv::Point2d(g[static_cast<std::size_t>(f)].point) - truth[static_cast<std::size_t>(f)].uv),
        0.05 * height)
        << f;
  }
  EXPECT_FALSE(segment_seeds(cv::Mat1b(480, 640, uchar(0)), &g, &why));
  EXPECT_EQ(why.rfind("segmentation: ", 0), 0u) << why;
  EXPECT_FALSE(extremity_seeds(cv::Mat1b(480, 640, uchar(0)), &s, &why));
  EXPECT_EQ(why, "silhouette too small to segment");
}

}  // namespace
}  // namespace vc::track
