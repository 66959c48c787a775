// Triangulation against hw/sim's ground truth: one point from exact, noisy and outlier-ridden views;
// the five features over whole motions (built-in and CMU clips) with noise, outliers, lost features and
// hands/feet labelled by image side — positions, the left/right naming and the confidence promise
// (a feature above the `confident` threshold is within 10 cm of the truth).
#include "voxcap/triangulate/triangulate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>

#include "voxcap/body/joints.hpp"
#include "voxcap/sim/rig_layout.hpp"
#include "voxcap/triangulate/synthetic.hpp"

namespace vc::triangulate {
namespace {

using testing::Noise;

std::vector<View> project_all(const rig::Calibration& cal, const cv::Vec3d& p, double sigma,
                              std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, sigma);
  std::vector<View> v;
  for (size_t c = 0; c < cal.cameras.size(); ++c) {
    // The draws sequenced: the order of a call's arguments is unspecified (gcc and clang differ).
    const double nx = n(rng);
    const double ny = n(rng);
    v.push_back({static_cast<int>(c), cal.cameras[c].project(p) + cv::Point2d(nx, ny), 0.9});
  }
  return v;
}

TEST(TriangulatePoint, ExactViewsGiveThePointWithDistortion) {
  sim::RigLayout layout;
  layout.cameras = 8;
  layout.distortion = true;
  const rig::Calibration cal = sim::default_rig(layout);
  std::mt19937_64 rng(1);
  const cv::Vec3d p(0.31, -0.22, 1.41);
  const PointResult r = triangulate_point(cal.cameras, project_all(cal, p, 0, rng), Options{});
  ASSERT_TRUE(r.ok);
  EXPECT_LT(cv::norm(r.p_world - p), 1e-6);
  EXPECT_LT(r.rms_px, 1e-4);
  EXPECT_EQ(r.inliers.size(), 8u);
  EXPECT_GT(r.confidence, 0.85);
}

TEST(TriangulatePoint, OutlierViewsAreVotedOut) {
  const rig::Calibration cal = sim::default_rig({});
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const double px = u(rng);
    const double py = u(rng);
    const double pz = u(rng);
    const cv::Vec3d p(0.8 * px, 0.8 * py, 1.0 + 0.8 * pz);
    std::vector<View> v = project_all(cal, p, 1.0, rng);
    // Two of six views are confident outliers, 30..100 px off.
    for (int k : {trial % 6, (trial + 3) % 6}) {
      const double du = u(rng);
      const double dv = u(rng);
      v[static_cast<size_t>(k)].uv_px += cv::Point2d(30 + 70 * std::abs(du), 40 * dv);
    }
    const PointResult r = triangulate_point(cal.cameras, v, Options{});
    ASSERT_TRUE(r.ok) << trial;
    EXPECT_LT(cv::norm(r.p_world - p), 0.025) << trial;  // four views, 1 px noise (~5 mm per pixel)
    EXPECT_EQ(r.inliers.size(), 4u) << trial;
    for (int i : r.inliers) EXPECT_TRUE(i != trial % 6 && i != (trial + 3) % 6) << trial;
  }
}

TEST(TriangulatePoint, TwoViewsAreNeverConfidentAndDisagreeingViewsGiveNoPoint) {
  const rig::Calibration cal = sim::default_rig({});
  std::mt19937_64 rng(3);
  const cv::Vec3d p(0.1, 0.2, 1.2);
  std::vector<View> v = project_all(cal, p, 0.5, rng);
  v.resize(2);
  v[0].weight = v[1].weight = 1.0;
  const PointResult two = triangulate_point(cal.cameras, v, Options{});
  ASSERT_TRUE(two.ok);
  EXPECT_LT(cv::norm(two.p_world - p), 0.02);
  EXPECT_LE(two.confidence, Options{}.confident);

  // Every view a different point, 0.3 m apart in height (the ring's epipolar lines run nearly
  // horizontally, so no two of them agree).
  std::vector<View> scattered;
  for (int c = 2; c < 6; ++c) {
    const cv::Vec3d q = p + cv::Vec3d(0, 0, 0.3 * (c - 2));
    scattered.push_back({c, cal.cameras[static_cast<size_t>(c)].project(q), 1.0});
  }
  EXPECT_FALSE(triangulate_point(cal.cameras, scattered, Options{}).ok);
  EXPECT_THROW(triangulate_point(cal.cameras, {{0, {1, 1}, 1}, {9, {1, 1}, 1}}, Options{}),
               std::invalid_argument);
}

TEST(TriangulateConfidence, FallsWithFewerViewsWorseFitAndNarrowGeometry) {
  const Options o;
  const double base = confidence(1, 4, 4, 0.5, 1.0, o);
  EXPECT_GT(base, 0.9);
  EXPECT_LT(confidence(1, 3, 3, 0.5, 1.0, o), base);
  EXPECT_LE(confidence(1, 2, 2, 0, 1.0, o), 0.5);
  EXPECT_LT(confidence(1, 4, 6, 0.5, 1.0, o), base);
  EXPECT_LT(confidence(1, 4, 4, 3.0, 1.0, o), base);
  EXPECT_LT(confidence(1, 4, 4, 0.5, 0.1, o), base);
  EXPECT_EQ(confidence(1, 1, 1, 0, 1.0, o), 0);
}

TEST(TriangulateOptions, ValidateThemselves) {
  Options o;
  std::string why;
  EXPECT_TRUE(o.valid(&why)) << why;
  o.inlier_px = 0;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_NE(why.find("inlier_px"), std::string::npos);
  o = Options{};
  o.swap_ratio = 1.5;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_THROW(FeatureTriangulator(sim::default_rig({}).cameras, {0, 1}, o), std::invalid_argument);
}

struct Figures {
  std::vector<double> err;  // triangulated, metres
  int frames = 0, named_wrong = 0, confident_wrong = 0, confident = 0, triangulated = 0;
  double worst_confident = 0;
};

// The performer's true right at `frame` (from the left hip to the right hip, level): what the fit's
// torso right stands for.
cv::Vec3d true_right(const sim::Scene& scene, int frame) {
  const auto j = scene.joints(frame);
  cv::Vec3d r = j[static_cast<size_t>(body::Joint::r_hip)] - j[static_cast<size_t>(body::Joint::l_hip)];
  r[2] = 0;
  return r / cv::norm(r);
}

Figures run(const std::string& motion, int cameras, int frames, int step, const Noise& noise, uint64_t seed,
            bool body_right = false) {
  sim::SceneOptions so;
  so.motion.source = motion;
  // The clip's path centred on the volume, as these figures were measured. With hw/sim's start in
  // the volume (issue #12) a 3.4 m walk ends, and is held for the rest of the 600 frames, 2.5 m out
  // in front beside the front cameras, where the right foot is triangulated 0.55 m off with
  // confidence 0.5-0.75 (cmu/02_01 from its frame 270): a limit of the triangulation there, not
  // of this test's subject.
  so.motion.bvh_start_within_x_m = so.motion.bvh_start_within_y_m = 0;
  so.rig.cameras = cameras;
  so.rig.distortion = true;
  const sim::Scene scene(so);
  const Options opt;
  FeatureTriangulator tri(scene.calibration().cameras, {0, 1}, opt);
  std::mt19937_64 rng(seed);
  Figures fig;
  for (int f = 0; f < frames; f += step) {
    const auto obs = testing::observe(scene, f, noise, rng);
    if (body_right) tri.set_body_right(true_right(scene, std::max(0, f - 3)));  // the fit lags a few frames
    const auto res = tri.process(obs);
    fig.frames++;
    for (int id = 0; id < 5; ++id) {
      const pipeline::Feature3D& r = res[static_cast<size_t>(id)];
      EXPECT_EQ(r.feature_id, id);
      if (r.state != pipeline::Feature3DState::Triangulated) continue;
      const cv::Vec3d p(r.p_world[0], r.p_world[1], r.p_world[2]);
      const double e = cv::norm(p - testing::truth(scene, f, id));
      fig.triangulated++;
      fig.err.push_back(e);
      if (id > 0) {
        const double other = cv::norm(p - testing::truth(scene, f, id % 2 == 1 ? id + 1 : id - 1));
        if (other + 0.05 < e) fig.named_wrong++;
      }
      if (r.confidence > opt.confident) {
        fig.confident++;
        fig.worst_confident = std::max(fig.worst_confident, e);
        if (e > 0.10) {
          fig.confident_wrong++;
          ADD_FAILURE() << motion << " frame " << f << " feature " << id << ": confident " << r.confidence
                        << " but " << e << " m off";
        }
      }
    }
  }
  std::sort(fig.err.begin(), fig.err.end());
  const auto pct = [&](double q) {
    return fig.err.empty() ? 0.0 : fig.err[static_cast<size_t>(q * static_cast<double>(fig.err.size() - 1))];
  };
  std::printf(
      "%s, %d cameras: %d frames, %d triangulated, %d confident, p50 %.1f mm, p95 %.1f mm, "
      "worst confident %.1f mm, named wrong %d\n",
      motion.c_str(), cameras, fig.frames, fig.triangulated, fig.confident, 1000 * pct(0.5), 1000 * pct(0.95),
      1000 * fig.worst_confident, fig.named_wrong);
  return fig;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * static_cast<double>(v.size() - 1))];
}

TEST(FeatureTriangulator, WalkWithNoiseOutliersAndImageSideLabels) {
  Noise n;
  n.sigma_px = 1.0;
  n.outlier = 0.05;
  n.lost = 0.05;
  n.predicted = 0.05;
  const Figures f = run("walk", 6, 420, 2, n, 11);
  EXPECT_EQ(f.confident_wrong, 0);
  EXPECT_GT(f.triangulated, f.frames * 4);
  EXPECT_GT(f.confident, f.triangulated / 2);
  EXPECT_LT(percentile(f.err, 0.5), 0.015);
  EXPECT_LT(percentile(f.err, 0.95), 0.04);
  EXPECT_LT(f.named_wrong, f.triangulated / 100 + 1);
}

TEST(FeatureTriangulator, HandsCrossingKeepTheirNames) {
  Noise n;
  n.sigma_px = 1.0;
  const Figures f = run("cross", 8, 300, 1, n, 12);
  EXPECT_EQ(f.confident_wrong, 0);
  EXPECT_EQ(f.named_wrong, 0);
  EXPECT_LT(percentile(f.err, 0.5), 0.015);
}

TEST(FeatureTriangulator, LabelsSwappedAtRandomPerCameraDoNotMatter) {
  Noise n;
  n.sigma_px = 1.0;
  n.outlier = 0.03;
  n.swap = 0.3;
  const Figures f = run("wave", 6, 480, 2, n, 21);
  EXPECT_EQ(f.confident_wrong, 0);
  EXPECT_LT(f.named_wrong, f.triangulated / 100 + 1);
  EXPECT_LT(percentile(f.err, 0.5), 0.015);
}

TEST(FeatureTriangulator, TurningInPlaceKeepsLeftAndRight) {
  Noise n;
  n.sigma_px = 1.5;
  n.outlier = 0.03;
  const Figures f = run("turn", 4, 360, 2, n, 13);
  EXPECT_EQ(f.confident_wrong, 0);
  EXPECT_LT(f.named_wrong, f.triangulated / 100 + 1);
}

// At start-up the edges may report feet held together as one blob (one candidate per camera): the
// pair is then first named from one point, which cannot tell left from right. As soon as the two feet
// are seen apart, still in the initialization pose, they must be named by it — not followed forever
// from the coin toss (live `walk` and `squat` had their feet swapped for the whole take this way).
TEST(FeatureTriangulator, FeetFirstSeenAsOnePointAreNamedByTheInitPose) {
  for (const uint64_t seed : {31u, 32u, 33u, 34u}) {
    sim::SceneOptions so;
    so.motion.source = "walk";
    const sim::Scene scene(so);
    FeatureTriangulator tri(scene.calibration().cameras, {0, 1}, Options{});
    std::mt19937_64 rng(seed);
    Noise n;
    n.sigma_px = 1.0;
    int wrong = 0, named = 0;
    for (int f = 0; f < 240; ++f) {
      auto obs = testing::observe(scene, f, n, rng);
      // Frames 0-4: each camera sees one foot blob between the two feet, reported as "left".
      // Coin tosses either way: the blob nearer one foot or the other.
      if (f < 5)
        for (CameraObservations& co : obs) {
          Observation& a = co.features[VC_FEATURE_LEFT_FOOT];
          Observation& b = co.features[VC_FEATURE_RIGHT_FOOT];
          if (!a.present || !b.present) continue;
          const double w = seed % 2 ? 0.4 : 0.6;
          a.uv_px = w * a.uv_px + (1 - w) * b.uv_px;
          b.present = false;
        }
      const auto res = tri.process(obs);
      if (f < 10) continue;  // the feet seen apart from frame 5: a few frames to name them
      for (int id : {VC_FEATURE_LEFT_FOOT, VC_FEATURE_RIGHT_FOOT}) {
        const pipeline::Feature3D& r = res[static_cast<size_t>(id)];
        if (r.state != pipeline::Feature3DState::Triangulated) continue;
        const cv::Vec3d p(r.p_world[0], r.p_world[1], r.p_world[2]);
        const double e = cv::norm(p - testing::truth(scene, f, id));
        const double other = cv::norm(p - testing::truth(scene, f, id == 3 ? 4 : 3));
        named++;
        if (other + 0.05 < e) wrong++;
      }
    }
    EXPECT_GT(named, 400) << "seed " << seed;
    EXPECT_EQ(wrong, 0) << "seed " << seed;
  }
}

// The body's right (README, "The body's right"). The rig's front cameras given as the ones behind the
// performer: the initialization rule names both pairs the wrong way round, and continuity and the
// cameras' kept swaps then keep that for the whole take. The body's right (the fit's torso right; here
// the truth, a few frames late) renames each pair and nothing then names it wrong again.
TEST(FeatureTriangulator, TheBodysRightRenamesAPairNamedTheWrongWayRound) {
  for (const char* motion : {"wave", "walk", "turn"}) {
    sim::SceneOptions so;
    so.motion.source = motion;
    const sim::Scene scene(so);
    // The cameras behind the performer at the first frame.
    const auto j0 = scene.joints(0);
    const cv::Vec3d& hips = j0[static_cast<size_t>(body::Joint::hips)];
    const cv::Vec3d facing = cv::Vec3d(0, 0, 1).cross(true_right(scene, 0));
    std::vector<int> behind;
    for (int c = 0; c < scene.camera_count(); ++c)
      if ((scene.calibration().cameras[static_cast<size_t>(c)].center_world() - hips).dot(facing) < 0)
        behind.push_back(c);
    ASSERT_GE(behind.size(), 2u) << motion;
    for (const bool hint : {false, true}) {
      FeatureTriangulator tri(scene.calibration().cameras, behind, Options{});
      std::mt19937_64 rng(41);
      Noise n;
      n.sigma_px = 1.0;
      int wrong = 0, named = 0, confident_wrong = 0;
      const int frames = 360;
      for (int f = 0; f < frames; ++f) {
        const auto obs = testing::observe(scene, f, n, rng);
        if (hint) tri.set_body_right(true_right(scene, std::max(0, f - 3)));
        const auto res = tri.process(obs);
        if (f < 30) continue;  // renamed within the first frames
        for (int id = VC_FEATURE_LEFT_HAND; id <= VC_FEATURE_RIGHT_FOOT; ++id) {
          const pipeline::Feature3D& r = res[static_cast<size_t>(id)];
          if (r.state != pipeline::Feature3DState::Triangulated) continue;
          const cv::Vec3d p(r.p_world[0], r.p_world[1], r.p_world[2]);
          const double e = cv::norm(p - testing::truth(scene, f, id));
          const double other = cv::norm(p - testing::truth(scene, f, id % 2 == 1 ? id + 1 : id - 1));
          named++;
          if (other + 0.05 < e) wrong++;
          if (r.confidence > Options{}.confident && e > 0.10) confident_wrong++;
        }
      }
      std::printf("%s, front cameras behind, %s the body's right: %d of %d named wrong, renames %d/%d\n",
                  motion, hint ? "with" : "without", wrong, named,
                  static_cast<int>(tri.body_renames(Pair::hands)),
                  static_cast<int>(tri.body_renames(Pair::feet)));
      EXPECT_GT(named, 1000) << motion;
      if (hint) {
        EXPECT_EQ(wrong, 0) << motion;
        EXPECT_EQ(confident_wrong, 0) << motion;
        EXPECT_GE(tri.body_renames(Pair::hands) + tri.body_renames(Pair::feet), 1u) << motion;
      } else {
        EXPECT_GT(wrong, named / 4) << motion << ": the start is not wrong; the test checks nothing";
      }
    }
  }
}

// The fit's torso sign flipped for 150 frames (cmu/02_06: the heading vote turned a correct torso round
// for 144 frames; cmu/01_01: a re-initialization from feet named the wrong way round): the body's right
// turns round from one frame to the next while the names, followed frame by frame, stay where they were.
// Names the body confirmed before it turned round are kept: 0 of 1320 named wrong on wave and turn;
// without the rule both pairs were renamed to the flipped torso 8 frames later and back after it (600 of
// 1320 wrong, 2 renames per pair).
TEST(FeatureTriangulator, ABodysRightThatTurnsRoundAtOnceDoesNotRename) {
  for (const char* motion : {"wave", "turn"}) {
    sim::SceneOptions so;
    so.motion.source = motion;
    const sim::Scene scene(so);
    FeatureTriangulator tri(scene.calibration().cameras, {0, 1}, Options{});
    std::mt19937_64 rng(61);
    Noise n;
    n.sigma_px = 1.0;
    int wrong = 0, named = 0, confident_wrong = 0;
    for (int f = 0; f < 360; ++f) {
      const auto obs = testing::observe(scene, f, n, rng);
      const cv::Vec3d r = true_right(scene, std::max(0, f - 3));
      tri.set_body_right(f >= 150 && f < 300 ? -r : r);
      const auto res = tri.process(obs);
      if (f < 30) continue;
      for (int id = VC_FEATURE_LEFT_HAND; id <= VC_FEATURE_RIGHT_FOOT; ++id) {
        const pipeline::Feature3D& ft = res[static_cast<size_t>(id)];
        if (ft.state != pipeline::Feature3DState::Triangulated) continue;
        const cv::Vec3d p(ft.p_world[0], ft.p_world[1], ft.p_world[2]);
        const double e = cv::norm(p - testing::truth(scene, f, id));
        const double other = cv::norm(p - testing::truth(scene, f, id % 2 == 1 ? id + 1 : id - 1));
        named++;
        if (other + 0.05 < e) wrong++;
        if (ft.confidence > Options{}.confident && e > 0.10) confident_wrong++;
      }
    }
    std::printf("%s, the body's right turned round for frames 150-299: %d of %d named wrong, renames %d/%d\n",
                motion, wrong, named, static_cast<int>(tri.body_renames(Pair::hands)),
                static_cast<int>(tri.body_renames(Pair::feet)));
    EXPECT_GT(named, 1000) << motion;
    EXPECT_EQ(wrong, 0) << motion;
    EXPECT_EQ(confident_wrong, 0) << motion;
    EXPECT_EQ(tri.body_renames(Pair::hands) + tri.body_renames(Pair::feet), 0u) << motion;
  }
}

// Hands crossing in front of the body contradict the body's right while they are crossed: they must
// keep their names (a crossing is brief and its hands are less than kBodyApartHandsM apart across it).
TEST(FeatureTriangulator, TheBodysRightLetsHandsCross) {
  Noise n;
  n.sigma_px = 1.0;
  const Figures f = run("cross", 6, 600, 1, n, 12, true);
  EXPECT_EQ(f.confident_wrong, 0);
  EXPECT_EQ(f.named_wrong, 0);
}

// Feet named while walking (README, "Left and right", the gate and the planted foot; "The body's
// right", strides). Per frame of `walk` (6 cameras, 1 px noise): the feet's names against the truth.
struct FeetFigures {
  int named = 0, wrong = 0, confident_wrong = 0;
};
void count_feet(const sim::Scene& scene, int f, const std::array<pipeline::Feature3D, 5>& res,
                FeetFigures* fig) {
  for (int id : {VC_FEATURE_LEFT_FOOT, VC_FEATURE_RIGHT_FOOT}) {
    const pipeline::Feature3D& r = res[static_cast<size_t>(id)];
    if (r.state != pipeline::Feature3DState::Triangulated) continue;
    const cv::Vec3d p(r.p_world[0], r.p_world[1], r.p_world[2]);
    const double e = cv::norm(p - testing::truth(scene, f, id));
    const double other = cv::norm(p - testing::truth(scene, f, id == 3 ? 4 : 3));
    fig->named++;
    if (other + 0.05 < e) fig->wrong++;
    if (r.confidence > Options{}.confident && e > 0.10) fig->confident_wrong++;
  }
}

// The feet tests' set-up: `walk`, the default rig (front cameras 0 and 1), 1 px noise.
sim::SceneOptions walking() {
  sim::SceneOptions so;
  so.motion.source = "walk";
  return so;
}
struct WalkingFeet {
  explicit WalkingFeet(uint64_t seed) : rng(seed) { noise.sigma_px = 1.0; }
  sim::Scene scene{walking()};
  FeatureTriangulator tri{scene.calibration().cameras, {0, 1}, Options{}};
  Noise noise;
  std::mt19937_64 rng;
  FeetFigures fig;
};

// For one frame now and then, while the feet are a stride apart, every camera's left foot track sits
// 10 cm beside the right foot (two tracks on one foot: cmu/02_01 live). The point it gives is farther
// from the left foot's prediction than a foot moves in a frame, so it is not named left; without the
// gate it took the left name and continuity then kept both feet swapped.
TEST(FeatureTriangulator, APointBesideTheOtherFootDoesNotTakeTheName) {
  WalkingFeet w(51);
  auto& [scene, tri, n, rng, fig] = w;
  int ghosts = 0;
  for (int f = 0; f < 420; ++f) {
    auto obs = testing::observe(scene, f, n, rng);
    const cv::Vec3d l = testing::truth(scene, f, VC_FEATURE_LEFT_FOOT);
    const cv::Vec3d r = testing::truth(scene, f, VC_FEATURE_RIGHT_FOOT);
    if (f >= 30 && f % 15 == 0 && cv::norm(l - r) > 0.4) {
      ++ghosts;
      const cv::Vec3d ghost = r + cv::Vec3d(0.07, 0.07, 0);
      for (CameraObservations& co : obs) {
        const rig::Camera& cam = scene.calibration().cameras[static_cast<size_t>(co.camera)];
        if (cam.to_cam(ghost)[2] <= 0) continue;
        for (Observation& o : co.features) {
          // The track that is on the left foot (by image position) moves to the ghost.
          if (&o == &co.features[VC_FEATURE_HEAD] || &o == &co.features[VC_FEATURE_LEFT_HAND] ||
              &o == &co.features[VC_FEATURE_RIGHT_HAND] || !o.present || o.state != VC_FEATURE_TRACKING)
            continue;
          const cv::Point2d ql = cam.project(l);
          if (std::hypot(o.uv_px.x - ql.x, o.uv_px.y - ql.y) < 5) o.uv_px = cam.project(ghost);
        }
      }
    }
    count_feet(scene, f, tri.process(obs), &fig);
  }
  std::printf("walk, a point beside the other foot on %d frames: %d of %d named wrong\n", ghosts, fig.wrong,
              fig.named);
  EXPECT_GE(ghosts, 5);
  EXPECT_GT(fig.named, 700);
  EXPECT_EQ(fig.wrong, 0);
  EXPECT_EQ(fig.confident_wrong, 0);
}

// A foot's track pulled by a wrong point, then one foot seen alone (cmu/02_03 live, where the performer
// comes back into the volume): every camera's left foot window sits between the feet for a frame (the
// point moves 70% of the way to the right foot), then the right foot is lost for a frame. Continuity from
// the pulled track gives the lone left foot the right name. Continuity there compares it with the other
// foot's old position only, so the name is reported untrusted unless the cameras' kept swaps vote for it.
// Without the rule every such lone foot was reported confident, 20-35 cm off.
TEST(FeatureTriangulator, AFootSeenAloneIsNotTrustedOnContinuityAlone) {
  WalkingFeet w(53);
  auto& [scene, tri, n, rng, fig] = w;
  int events = 0, pulled = -100;
  FeetFigures window, alone;
  for (int f = 0; f < 420; ++f) {
    auto obs = testing::observe(scene, f, n, rng);
    const cv::Vec3d l = testing::truth(scene, f, VC_FEATURE_LEFT_FOOT);
    const cv::Vec3d r = testing::truth(scene, f, VC_FEATURE_RIGHT_FOOT);
    const double apart = cv::norm(l - r);
    const bool pull = f >= 30 && f - pulled >= 40 && apart > 0.15 && apart < 0.24;
    if (pull) {
      pulled = f;
      ++events;
    }
    for (CameraObservations& co : obs) {
      const rig::Camera& cam = scene.calibration().cameras[static_cast<size_t>(co.camera)];
      // Each camera's foot tracks keep their identity (as the edges' trackers do, not by image side).
      Observation& ol = co.features[VC_FEATURE_LEFT_FOOT];
      Observation& orr = co.features[VC_FEATURE_RIGHT_FOOT];
      if (ol.state == VC_FEATURE_TRACKING && orr.state == VC_FEATURE_TRACKING) {
        const cv::Point2d ql = cam.project(l);
        if (std::hypot(orr.uv_px.x - ql.x, orr.uv_px.y - ql.y) <
            std::hypot(ol.uv_px.x - ql.x, ol.uv_px.y - ql.y))
          std::swap(ol, orr);
      }
      for (int id : {VC_FEATURE_LEFT_FOOT, VC_FEATURE_RIGHT_FOOT}) {
        Observation& o = co.features[static_cast<size_t>(id)];
        if (!o.present || o.state != VC_FEATURE_TRACKING) continue;
        const cv::Point2d ql = cam.project(l), qr = cam.project(r);
        if (pull && std::hypot(o.uv_px.x - ql.x, o.uv_px.y - ql.y) < 5)
          o.uv_px = cam.project(l + 0.7 * (r - l));
        if (f == pulled + 1 && std::hypot(o.uv_px.x - qr.x, o.uv_px.y - qr.y) < 5) o.state = VC_FEATURE_LOST;
      }
    }
    // The pulled frame's point is the window's, all cameras agreeing: counted apart.
    count_feet(scene, f, tri.process(obs), f == pulled ? &window : f == pulled + 1 ? &alone : &fig);
  }
  std::printf(
      "walk, a foot's track pulled then the other foot lost, %d times: the lone foot named wrong %d "
      "times, %d of them confident\n",
      events, alone.wrong, alone.confident_wrong);
  EXPECT_GE(events, 3);
  EXPECT_GT(fig.named, 700);
  EXPECT_GE(alone.wrong, events / 2);  // the scenario bites: continuity names the lone foot wrong
  EXPECT_EQ(alone.confident_wrong, 0);
}

// The fit's torso right 30° off while walking (live cmu/02_01: 20-30° for tens of frames): a stride
// fore-aft then lies 25 cm "sideways" along it, against the names half the time. Feet apart more
// fore-aft than sideways are not judged by it; without that the feet were renamed on every other step.
TEST(FeatureTriangulator, ABodysRightTurned30DegreesDoesNotRenameStrides) {
  WalkingFeet w(52);
  auto& [scene, tri, n, rng, fig] = w;
  const double a = 30.0 * 3.14159265358979 / 180.0;
  for (int f = 0; f < 420; ++f) {
    const auto obs = testing::observe(scene, f, n, rng);
    const cv::Vec3d r = true_right(scene, std::max(0, f - 3));
    tri.set_body_right(
        cv::Vec3d(std::cos(a) * r[0] - std::sin(a) * r[1], std::sin(a) * r[0] + std::cos(a) * r[1], 0));
    count_feet(scene, f, tri.process(obs), &fig);
  }
  std::printf("walk, the body's right 30 deg off: %d of %d named wrong, renames %d\n", fig.wrong, fig.named,
              static_cast<int>(tri.body_renames(Pair::feet)));
  EXPECT_GT(fig.named, 700);
  EXPECT_EQ(fig.wrong, 0);
  EXPECT_EQ(fig.confident_wrong, 0);
  EXPECT_EQ(tri.body_renames(Pair::feet), 0u);
}

TEST(FeatureTriangulator, CmuClipsNeverConfidentlyWrong) {
  const std::filesystem::path dir = std::filesystem::path(VOXCAP_SHARED_DIR) / "data/mocap/cmu";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << "no CMU clips in " << dir;
  Noise n;
  n.sigma_px = 1.5;
  n.outlier = 0.05;
  n.lost = 0.05;
  int clips = 0;
  for (const char* clip : {"02_01.bvh", "05_02.bvh", "09_01.bvh"}) {
    if (!std::filesystem::exists(dir / clip)) continue;
    const Figures f = run((dir / clip).string(), 6, 600, 3, n, 14 + static_cast<uint64_t>(clips));
    EXPECT_EQ(f.confident_wrong, 0) << clip;
    EXPECT_LT(percentile(f.err, 0.5), 0.02) << clip;
    ++clips;
  }
  EXPECT_GT(clips, 0);
}

}  // namespace
}  // namespace vc::triangulate
