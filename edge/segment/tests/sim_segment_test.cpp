// edge/segment against the virtual rig's truth (hw/sim): the initialization frame of `wave` seen by
// every camera of rigs of 4, 6 and 8 cameras (true silhouettes), and the edge's own masks
// (edge/core's subtraction and clean-up, as tests/bench/silhouette_bench.cpp runs them) for the
// appearance presets. Left/right are per image (left = the image's right), so the truth's pairs are
// ordered by image side before comparing.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/segment.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/subtraction.h"

namespace vc::segment {
namespace {

struct View {
  cv::Mat1b mask;
  std::array<cv::Point2d, kFeatures> truth;  // ordered by image side
  std::array<bool, kFeatures> visible{};
};

struct ModelFree {
  void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
};

// The edge's mask of a frame: background model from empty frames, vc_subtract, vc_cleanup_radius.
cv::Mat1b edge_mask(const sim::Scene& scene, int cam, const cv::Mat& rgb) {
  vc_bgmodel* made = nullptr;
  char why[160];
  if (vc_bgmodel_new(rgb.cols, rgb.rows, &made, why, sizeof why) != 0) throw std::runtime_error(why);
  std::unique_ptr<vc_bgmodel, ModelFree> m(made);
  cv::Mat bg;
  for (int i = 0; i < 12; i++) {
    scene.render_background(cam, i, bg);
    if (vc_bgmodel_learn(m.get(), bg.data, bg.step) != 0) throw std::runtime_error("learn");
  }
  vc_subtract_params p;
  vc_subtract_params_default(&p);
  if (vc_bgmodel_finish(m.get()) != 0 || vc_bgmodel_set_params(m.get(), &p) != 0)
    throw std::runtime_error("finish");
  cv::Mat1b mask(rgb.rows, rgb.cols);
  std::vector<uint8_t> scratch(vc_cleanup_radius_scratch_size(rgb.cols, VC_CLEANUP_RADIUS_PX));
  vc_subtract_stats st{};
  if (vc_subtract(m.get(), rgb.data, rgb.step, mask.data, &st) != 0 ||
      vc_cleanup_radius(mask.data, rgb.cols, rgb.rows, VC_CLEANUP_RADIUS_PX, scratch.data(),
                        scratch.size()) != 0)
    throw std::runtime_error("subtract");
  return mask;
}

std::vector<View> init_views(int cameras, const std::string& appearance, bool edge, int width = 640,
                             int height = 480, const std::string& room = "default") {
  sim::SceneOptions o;
  o.motion.source = "wave";
  o.appearance = appearance;
  o.room = room;
  o.rig.cameras = cameras;
  o.rig.width = width;
  o.rig.height = height;
  const sim::Scene scene(o);
  std::vector<View> views;
  for (int cam = 0; cam < scene.camera_count(); cam++) {
    View v;
    cv::Mat rgb, sil;
    scene.render(0, cam, rgb, &sil);
    v.mask = edge ? edge_mask(scene, cam, rgb) : cv::Mat1b(sil);
    const std::vector<sim::FeatureTruth> t = scene.features(0, cam);
    for (size_t f = 0; f < kFeatures; f++) v.truth[f] = t[f].uv, v.visible[f] = t[f].visible;
    for (size_t l : {size_t{1}, size_t{3}})
      if (v.truth[l].x < v.truth[l + 1].x)
        std::swap(v.truth[l], v.truth[l + 1]), std::swap(v.visible[l], v.visible[l + 1]);
    views.push_back(v);
  }
  return views;
}

struct Score {
  int ok = 0;
  std::vector<double> errors;  // visible features of the cameras that segmented
};

// Checks the labels of every camera that segmented: head and hands nearer their own truth than any
// other feature's; every visible feature within max_err_ratio x the silhouette's height.
Score check(const std::vector<View>& views, double max_err_ratio, const std::string& what) {
  Score sc;
  for (size_t c = 0; c < views.size(); c++) {
    const View& v = views[c];
    const Segmentation s = segment(v.mask);
    if (!s.ok) {
      EXPECT_FALSE(s.why.empty());
      continue;
    }
    sc.ok++;
    const double h = cv::boundingRect(v.mask).height;
    for (size_t f = 0; f < kFeatures; f++) {
      const cv::Point2d p(s.point[f].x, s.point[f].y);
      const double e = cv::norm(p - v.truth[f]);
      if (f <= kRightHand) {
        for (size_t g = 0; g < kFeatures; g++)
          if (g != f)
            EXPECT_LT(e, cv::norm(p - v.truth[g]))
                << what << " cam " << c << ": " << feature_name(static_cast<int>(f)) << " is nearer "
                << feature_name(static_cast<int>(g));
      }
      if (!v.visible[f]) continue;
      EXPECT_LT(e, max_err_ratio * h) << what << " cam " << c << " " << feature_name(static_cast<int>(f));
      sc.errors.push_back(e);
    }
  }
  return sc;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Rigs of 4, 6 and 8 cameras, true silhouettes. With 8 cameras two look along the arms (one hides
// behind the torso): those refuse with a reason (measured: 6 of 8 segment).
TEST(SimSegment, RigsOf4_6_8Cameras) {
  const std::array<std::pair<int, int>, 3> rigs{{{4, 4}, {6, 6}, {8, 6}}};
  for (const auto& [cameras, want_ok] : rigs) {
    const std::string what = std::to_string(cameras) + " cameras";
    const Score sc = check(init_views(cameras, "default", false), 0.1, what);
    EXPECT_GE(sc.ok, want_ok) << what;
    EXPECT_LT(median(sc.errors), 3.0) << what;  // measured 1.8 .. 2.4 px at 640x480
  }
}

// The edge's real masks, default room, every appearance preset. `dark`'s masks lose the head in
// front of the blue painting (cam 1) and parts of an arm (cam 5) today (edge/core's issue #10):
// those cameras must refuse, not label wrongly; the others are checked like the rest.
TEST(SimSegment, EdgeMasksOfTheAppearancePresets) {
  const std::array<std::pair<const char*, int>, 6> presets{
      {{"default", 6}, {"pale", 6}, {"olive", 6}, {"brown", 6}, {"beige", 6}, {"dark", 4}}};
  for (const auto& [a, want_ok] : presets) {
    const Score sc = check(init_views(6, a, true), 0.1, a);
    EXPECT_GE(sc.ok, want_ok) << a;
    EXPECT_LT(median(sc.errors), 4.0) << a;  // measured 2.0 .. 3.5 px
  }
}

// The camouflage room (beige tiled floor, walls close to the shirts): the edge's masks lose the head
// of the front pair against the blue wall; those refuse, the others segment (measured 4 of 6).
TEST(SimSegment, EdgeMasksInTheCamouflageRoom) {
  const Score sc = check(init_views(6, "default", true, 640, 480, "camouflage"), 0.1, "camouflage");
  EXPECT_GE(sc.ok, 4);
  EXPECT_LT(median(sc.errors), 6.0);  // measured 5.0 px
}

// 320x240: the body is ~110 px high, arms ~4 px wide.
TEST(SimSegment, SmallImages) {
  const Score sc = check(init_views(6, "default", false, 320, 240), 0.12, "320x240");
  EXPECT_GE(sc.ok, 4);
}

}  // namespace
}  // namespace vc::segment
