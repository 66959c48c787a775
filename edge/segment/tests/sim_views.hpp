// Test and survey support for edge/segment against the virtual rig (hw/sim): the initialization
// frames of a scene seen by every camera, with the true silhouette, the edge's own mask (edge/core's
// subtraction and clean-up, as tests/bench/silhouette_bench.cpp runs them) and the true 2D features;
// and the score of one segmentation against that truth. Used by sim_segment_test.cpp and
// bench/segment_survey.cpp; ground truth, so never linked into what the edge runs.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/segment.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/subtraction.h"

namespace vc::segment::testing {

struct ModelFree {
  void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
};

// The edge's masks of one scene: a background model per camera from 12 empty frames, then per frame
// vc_subtract and vc_cleanup_radius with the defaults.
class EdgeMasks {
 public:
  explicit EdgeMasks(const sim::Scene& scene) {
    for (int cam = 0; cam < scene.camera_count(); cam++) {
      cv::Mat bg;
      scene.render_background(cam, 0, bg);
      vc_bgmodel* made = nullptr;
      char why[160];
      if (vc_bgmodel_new(bg.cols, bg.rows, &made, why, sizeof why) != 0) throw std::runtime_error(why);
      models_.emplace_back(made);
      for (int i = 0; i < 12; i++) {
        if (i > 0) scene.render_background(cam, i, bg);
        if (vc_bgmodel_learn(made, bg.data, bg.step) != 0) throw std::runtime_error("bgmodel learn");
      }
      vc_subtract_params p;
      vc_subtract_params_default(&p);
      if (vc_bgmodel_finish(made) != 0 || vc_bgmodel_set_params(made, &p) != 0)
        throw std::runtime_error("bgmodel finish");
    }
  }
  cv::Mat1b mask(int cam, const cv::Mat& rgb) const {
    cv::Mat1b mask(rgb.rows, rgb.cols);
    std::vector<std::uint8_t> scratch(vc_cleanup_radius_scratch_size(rgb.cols, VC_CLEANUP_RADIUS_PX));
    vc_subtract_stats st{};
    if (vc_subtract(models_.at(static_cast<size_t>(cam)).get(), rgb.data, rgb.step, mask.data, &st) != 0 ||
        vc_cleanup_radius(mask.data, rgb.cols, rgb.rows, VC_CLEANUP_RADIUS_PX, scratch.data(),
                          scratch.size()) != 0)
      throw std::runtime_error("subtract");
    return mask;
  }

 private:
  std::vector<std::unique_ptr<vc_bgmodel, ModelFree>> models_;
};

// One camera's view of one frame. Left/right of the truth are ordered by image side like segment()'s
// labels (left = the one on the image's right).
struct View {
  int camera = 0;
  cv::Mat1b truth_mask, edge_mask;
  std::array<cv::Point2d, kFeatures> truth;
  std::array<bool, kFeatures> visible{};
  std::array<bool, kFeatures> in_image{};
};

inline sim::SceneOptions init_scene(int cameras, const std::string& appearance, const std::string& room,
                                    int width = 640, int height = 480) {
  sim::SceneOptions o;
  o.motion.source = "wave";  // every motion starts in the initialization pose (held 1 s)
  o.appearance = appearance;
  o.room = room;
  o.rig.cameras = cameras;
  o.rig.width = width;
  o.rig.height = height;
  return o;
}

// Every camera's view of `frame`; the edge's masks only when `edge` is given.
inline std::vector<View> views(const sim::Scene& scene, int frame, const EdgeMasks* edge) {
  std::vector<View> out;
  for (int cam = 0; cam < scene.camera_count(); cam++) {
    View v;
    v.camera = cam;
    cv::Mat rgb, sil;
    scene.render(frame, cam, rgb, &sil);
    v.truth_mask = sil;
    if (edge) v.edge_mask = edge->mask(cam, rgb);
    const std::vector<sim::FeatureTruth> t = scene.features(frame, cam);
    for (size_t f = 0; f < kFeatures; f++)
      v.truth[f] = t[f].uv, v.visible[f] = t[f].visible, v.in_image[f] = t[f].in_image;
    for (size_t l : {size_t{1}, size_t{3}})
      if (v.truth[l].x < v.truth[l + 1].x)
        std::swap(v.truth[l], v.truth[l + 1]), std::swap(v.visible[l], v.visible[l + 1]),
            std::swap(v.in_image[l], v.in_image[l + 1]);
    out.push_back(std::move(v));
  }
  return out;
}

// A terminal is labelled correctly when
//   - its feature is visible: it is labelled, within tolerance_ratio x the true silhouette's height
//   (kToleranceRatio) of
//     its true 2D position, and nearer that than any other feature's; when the two of a pair are
//     within the tolerance of the same image column, either image-side order is right (the host
//     agrees left/right by triangulating, so only a consistent order per view matters);
//   - its feature is hidden (occluded or outside the image): it is not labelled (not_visible), or
//     labelled within the tolerance of where it is (a hand just peeking out).
// A camera that refuses (ok == false) labels nothing: each visible feature is a miss.
struct TerminalScore {
  bool visible = false, labelled = false, correct = false;
  double error_px = -1;  // labelled: distance to the truth (the pair's other order when that was taken)
};
struct CameraScore {
  bool ok = false;
  std::string why;
  std::array<TerminalScore, kFeatures> t{};
  bool all_correct() const {
    return std::all_of(t.begin(), t.end(), [](const TerminalScore& s) { return s.correct; });
  }
};

// A hand is ~0.1 of the body's height from wrist to finger tips, a foot ~0.15 from ankle to toes:
// within 0.08 of the height of its joint a label lies on its part.
inline constexpr double kToleranceRatio = 0.08;

inline CameraScore score(const Segmentation& s, const View& v, double tolerance_ratio = kToleranceRatio) {
  CameraScore c;
  c.ok = s.ok;
  c.why = s.why;
  const double tol = tolerance_ratio * cv::boundingRect(v.truth_mask).height;
  std::array<size_t, kFeatures> truth_of{0, 1, 2, 3, 4};
  std::array<bool, kFeatures> one_column{};
  for (size_t l : {size_t{1}, size_t{3}}) {
    // Pairs on nearly one column: take the order that fits (both labelled, visible or not), and
    // the partner is no "other feature" to be nearer (which is which is the host's to agree).
    if (!s.ok || s.terminal[l] < 0 || s.terminal[l + 1] < 0) continue;
    if (std::abs(v.truth[l].x - v.truth[l + 1].x) >= tol) continue;
    one_column[l] = one_column[l + 1] = true;
    auto d = [&](size_t a, size_t b) {
      return cv::norm(cv::Point2d(s.point[a].x, s.point[a].y) - v.truth[b]);
    };
    if (d(l, l + 1) + d(l + 1, l) < d(l, l) + d(l + 1, l + 1)) truth_of[l] = l + 1, truth_of[l + 1] = l;
  }
  for (size_t f = 0; f < kFeatures; f++) {
    TerminalScore& t = c.t[f];
    const size_t tf = truth_of[f];
    t.visible = v.visible[tf];
    t.labelled = s.ok && s.terminal[f] >= 0;
    if (!t.labelled) {
      t.correct = !t.visible;
      continue;
    }
    const cv::Point2d p(s.point[f].x, s.point[f].y);
    t.error_px = cv::norm(p - v.truth[tf]);
    bool nearest = true;
    for (size_t g = 0; g < kFeatures; g++)
      if (g != tf && v.in_image[g] && cv::norm(p - v.truth[g]) <= t.error_px &&
          !(one_column[f] && g == truth_of[f % 2 == 1 ? f + 1 : f - 1]))  // the partner's truth
        nearest = false;
    t.correct = t.error_px <= tol && (nearest || !t.visible);
  }
  return c;
}

}  // namespace vc::segment::testing
