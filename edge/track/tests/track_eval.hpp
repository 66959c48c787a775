// Runs CameraTrackers over the virtual rig (hw/sim) and scores them against its truth: per feature the
// 2D error while the feature is visible and tracked, how often a visible feature was not tracked, the
// losses and the frames each loss took to recover once the part was visible again. Shared by the unit
// tests (tracker_test.cpp) and the benchmark (tests/bench/track_bench.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "voxcap/body/joints.hpp"
#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/track/tracker.hpp"
#include "voxcap/sim/rig_layout.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::track::eval {

enum class Masks { truth, edge };  // the true silhouettes, or the edge's own subtraction + clean-up

struct EvalOptions {
  std::string motion = "wave";
  std::string appearance = "default";
  std::string room = "default";
  int cameras = 6;
  int first_frame = 0;  // the init pose holds for the first 60 frames
  int frames = 240;     // frames to run (from first_frame)
  int frame_step = 1;
  Masks masks = Masks::edge;
  int grow_px = -1;  // the edge's limb-scale cue (bgmodel.h grow_px) for edge masks; < 0: the edge's default
  bool truth_seeds = true;  // seeds from the truth (else the tracker's own seeder)
  int trace_feature =
      -1;  // >= 0: print every camera frame of this feature (cam frame state conf err uv truth)
  TrackerOptions tracker;
};

struct FeatureScore {
  std::vector<double> errors;     // px, visible & tracking
  int visible = 0;                // frames where the truth says visible
  int visible_untracked = 0;      // ... and the tracker did not report tracking
  int losses = 0;                 // tracking -> not tracking while the part is visible
  std::vector<int> recover;       // frames from the part being visible again (after a loss) to tracking
  int unrecovered = 0;            // losses still open at the end while the part was visible for > 10 frames
  int far_tracking = 0;           // tracking with an error > 25 px (a confident wrong answer in 2D)
  int far_confident = 0;          // ... with confidence above 0.5 (the host's `confident`)
  std::vector<double> predicted;  // px, visible & predicted (counted as untracked too)
  std::vector<std::vector<double>> per_camera;  // the errors, per camera
  cv::Point2d bias{0, 0};  // summed (reported - true) over tracking errors <= 25 px (mean: / near)
  int near = 0;
  double pct(double q) const { return pct_of(errors, q); }
  static double pct_of(const std::vector<double>& v, double q) {
    if (v.empty()) return NAN;
    std::vector<double> e = v;
    const auto k = static_cast<std::size_t>(std::clamp(q * double(e.size() - 1), 0.0, double(e.size() - 1)));
    std::nth_element(e.begin(), e.begin() + long(k), e.end());
    return e[k];
  }
};

// The error in the limb's own frame, summed over the tracked reports within 25 px (2D, per camera) or
// over the frames a point could be triangulated (3D): where the reported point sits against the joint.
// Hands: `along` the forearm (elbow -> wrist, + = towards the fingers), `across` it (2D: signed, image
// normal to the forearm's projection; 3D: the length of the rest). Feet: `along` the shank (knee ->
// ankle, + = down), `forward` along the foot (ankle -> toe, orthogonal to the shank; 3D only, in 2D
// `across` the shank's projection). Head: image x / y (2D), world-frame length (3D).
struct LimbBias {
  double along = 0, across = 0, forward = 0, dist = 0;
  std::vector<double> err_mm;  // 3D only: the error of each triangulated point
  int n = 0;
  void add(double a, double c, double f, double d) { along += a, across += c, forward += f, dist += d, n++; }
  double mean(double LimbBias::*m) const { return n ? this->*m / n : NAN; }
};

struct EvalResult {
  std::array<FeatureScore, kFeatures> features;
  std::array<LimbBias, kFeatures> bias2d, bias3d;
  double track_ms_per_camera_frame = 0;  // mean, tracking phase only
  int camera_frames = 0;
  std::vector<double> all_errors() const {
    std::vector<double> a;
    for (const auto& f : features) a.insert(a.end(), f.errors.begin(), f.errors.end());
    return a;
  }
};

// The truth's features in a camera, in vc_feature_id order (hw/body's Feature order is the wire's).
inline std::array<sim::FeatureTruth, kFeatures> truth_features(const sim::Scene& scene, int frame, int cam) {
  std::array<sim::FeatureTruth, kFeatures> t{};
  for (const auto& ft : scene.features(frame, cam)) t[static_cast<std::size_t>(ft.feature)] = ft;
  return t;
}

// Left/right as the tracker's seeder decides them: by image side as if the camera faced the performer
// (the performer's left hand on the image's right). The truth says which joint; this says which of the
// pair an image-side seeder would call left in this camera's init frame.
inline bool sides_swapped(const sim::Scene& scene, int frame, int cam) {
  const auto t = truth_features(scene, frame, cam);
  return t[1].uv.x < t[2].uv.x;  // the performer's left hand left of the right one: seen from behind
}

// The limb a feature's joint ends: {proximal joint, the joint, the distal joint}.
inline std::array<int, 3> limb_of(int true_feature) {
  using J = body::Joint;
  static const std::array<std::array<J, 3>, kFeatures> limbs = {{{J::neck, J::head, J::head_top},
                                                                 {J::l_elbow, J::l_wrist, J::l_hand_tip},
                                                                 {J::r_elbow, J::r_wrist, J::r_hand_tip},
                                                                 {J::l_knee, J::l_ankle, J::l_toe},
                                                                 {J::r_knee, J::r_ankle, J::r_toe}}};
  const auto& l = limbs[static_cast<std::size_t>(true_feature)];
  return {int(l[0]), int(l[1]), int(l[2])};
}

// The point nearest (least squares) to the rays through uv of the given cameras.
inline bool intersect_rays(const rig::Calibration& cal, const std::vector<std::pair<int, cv::Point2d>>& uvs,
                           cv::Vec3d* p) {
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0);
  for (const auto& [cam, uv] : uvs) {
    const rig::Camera& c = cal.cameras[static_cast<std::size_t>(cam)];
    const cv::Vec3d d = c.ray_world(uv), o = c.center_world();
    const cv::Matx33d P = cv::Matx33d::eye() - d * d.t();
    A += P;
    b += P * o;
  }
  if (uvs.size() < 2) return false;
  return cv::solve(A, b, *p, cv::DECOMP_CHOLESKY);
}

inline EvalResult evaluate(const EvalOptions& o) {
  sim::SceneOptions so;
  so.motion.source = o.motion;
  so.appearance = o.appearance;
  so.room = o.room;
  so.rig.cameras = o.cameras;
  sim::Scene scene(so);
  EvalResult res;
  const int W = so.rig.width, H = so.rig.height;
  // Per frame and true feature: the cameras that tracked it (confidence > 0.5) and where.
  std::vector<std::array<std::vector<std::pair<int, cv::Point2d>>, kFeatures>> tracked(
      static_cast<std::size_t>(o.frames));
  for (int cam = 0; cam < o.cameras; ++cam) {
    const bool swap = sides_swapped(scene, 0, cam);
    const rig::Camera& camera = scene.calibration().cameras[static_cast<std::size_t>(cam)];
    auto map_truth = [&](int frame) {
      auto t = truth_features(scene, frame, cam);
      if (swap) std::swap(t[1], t[2]), std::swap(t[3], t[4]);
      return t;
    };
    int frame = o.first_frame;
    Seeder seeder = nullptr;
    if (o.truth_seeds)
      seeder = [&](const cv::Mat1b&, Seeds* seeds, std::string*) {
        const auto t = map_truth(frame);
        for (int f = 0; f < kFeatures; ++f)
          (*seeds)[static_cast<std::size_t>(f)] = {t[static_cast<std::size_t>(f)].visible,
                                                   cv::Point2f(t[static_cast<std::size_t>(f)].uv)};
        return true;
      };
    CameraTracker tracker(o.tracker, seeder);
    vc_bgmodel* bg = nullptr;
    std::vector<std::uint8_t> scratch;
    if (o.masks == Masks::edge) {
      char why[256];
      if (vc_bgmodel_new(W, H, &bg, why, sizeof(why)) < 0) throw std::runtime_error(why);
      cv::Mat b;
      for (int i = 0; i < 30; ++i) {
        scene.render_background(cam, i, b);
        vc_bgmodel_learn(bg, b.data, b.step);
      }
      vc_bgmodel_finish(bg);
      vc_subtract_params p;
      vc_subtract_params_default(&p);
      if (o.grow_px >= 0) p.grow_px = o.grow_px;
      if (vc_bgmodel_set_params(bg, &p) < 0) throw std::runtime_error("bad subtraction parameters");
      scratch.resize(vc_cleanup_radius_scratch_size(W, VC_CLEANUP_RADIUS_PX));
    }
    std::unique_ptr<vc_bgmodel, void (*)(vc_bgmodel*)> bg_owner(bg, vc_bgmodel_free);
    cv::Mat rgb, sil;
    cv::Mat1b mask(H, W);
    std::array<bool, kFeatures> was_tracking{}, pending{};
    std::array<int, kFeatures> visible_since_loss{};
    double ms = 0;
    int timed = 0;
    for (int i = 0; i < o.frames; ++i, frame += o.frame_step) {
      scene.render(frame, cam, rgb, &sil);
      if (bg) {
        // the edge's silhouette as the node makes it (edge/daemon/node.c): subtraction, clean-up, cue;
        // and as the node gives it to its tracker, without the cue's pixels
        vc_mask_frame(bg, rgb.data, rgb.step, mask.data, VC_CLEANUP_RADIUS_PX, scratch.data(), scratch.size(),
                      nullptr);
        vc_mask_ungrown(mask.data, mask.total(), mask.data);
      } else {
        sil.copyTo(mask);
      }
      FrameReport rep;
      const bool timing = tracker.initialised();
      const auto t0 = std::chrono::steady_clock::now();
      tracker.process(rgb, mask, &rep);
      const auto t1 = std::chrono::steady_clock::now();
      if (timing) ms += std::chrono::duration<double, std::milli>(t1 - t0).count(), timed++;
      if (!tracker.initialised()) continue;
      const auto truth = map_truth(frame);
      for (int f = 0; f < kFeatures; ++f) {
        const auto fs = static_cast<std::size_t>(f);
        FeatureScore& s = res.features[fs];
        const bool vis = truth[fs].visible;
        const bool trk = rep[fs].state == FeatureState::tracking;
        if (f == o.trace_feature)
          std::printf(
              "trace cam %d frame %d state %d vis %d conf %.2f err %.1f uv %.1f,%.1f truth %.1f,%.1f\n", cam,
              frame, int(rep[fs].state), int(vis), double(rep[fs].confidence),
              cv::norm(cv::Point2d(rep[fs].uv) - truth[fs].uv), double(rep[fs].uv.x), double(rep[fs].uv.y),
              truth[fs].uv.x, truth[fs].uv.y);
        if (vis) {
          s.visible++;
          if (trk) {
            const double e = cv::norm(cv::Point2d(rep[fs].uv) - truth[fs].uv);
            s.errors.push_back(e);
            s.per_camera.resize(static_cast<std::size_t>(o.cameras));
            s.per_camera[static_cast<std::size_t>(cam)].push_back(e);
            const int tf = swap && f > 0 ? (f % 2 == 1 ? f + 1 : f - 1) : f;  // the true feature
            if (e > 25) {
              s.far_tracking++, s.far_confident += rep[fs].confidence > 0.5f;
            } else {
              const cv::Point2d d = cv::Point2d(rep[fs].uv) - truth[fs].uv;
              s.bias += d, s.near++;
              const auto limb = limb_of(tf);
              const auto j = scene.joints(frame);
              cv::Point2d axis = camera.project(j[static_cast<std::size_t>(limb[1])]) -
                                 camera.project(j[static_cast<std::size_t>(limb[0])]);
              if (f == 0) axis = {0, 1};  // the head: image x / y
              const double len = cv::norm(axis);
              if (len > 1e-6) {
                axis /= len;
                res.bias2d[fs].add(d.dot(axis), axis.x * d.y - axis.y * d.x, 0, e);
              }
            }
            if (rep[fs].confidence > 0.5f)
              tracked[static_cast<std::size_t>(i)][static_cast<std::size_t>(tf)].emplace_back(
                  cam, cv::Point2d(rep[fs].uv));
          } else {
            s.visible_untracked++;
            if (rep[fs].state == FeatureState::predicted)
              s.predicted.push_back(cv::norm(cv::Point2d(rep[fs].uv) - truth[fs].uv));
          }
        }
        if (was_tracking[fs] && !trk && vis) s.losses++, pending[fs] = true, visible_since_loss[fs] = 0;
        if (pending[fs]) {
          if (trk) {
            s.recover.push_back(visible_since_loss[fs]);
            pending[fs] = false;
          } else if (vis) {
            visible_since_loss[fs]++;
          }
        }
        was_tracking[fs] = trk;
      }
    }
    for (int f = 0; f < kFeatures; ++f)
      if (pending[static_cast<std::size_t>(f)] && visible_since_loss[static_cast<std::size_t>(f)] > 10)
        res.features[static_cast<std::size_t>(f)].unrecovered++;
    res.track_ms_per_camera_frame += ms;
    res.camera_frames += timed;
  }
  if (res.camera_frames) res.track_ms_per_camera_frame /= res.camera_frames;
  for (int i = 0; i < o.frames; ++i) {
    const auto j = scene.joints(o.first_frame + i * o.frame_step);
    for (int f = 0; f < kFeatures; ++f) {
      cv::Vec3d p;
      if (!intersect_rays(scene.calibration(),
                          tracked[static_cast<std::size_t>(i)][static_cast<std::size_t>(f)], &p))
        continue;
      const auto limb = limb_of(f);
      const cv::Vec3d& a = j[static_cast<std::size_t>(limb[0])];
      const cv::Vec3d& w = j[static_cast<std::size_t>(limb[1])];
      const cv::Vec3d& t = j[static_cast<std::size_t>(limb[2])];
      const cv::Vec3d d = p - w;
      LimbBias& b = res.bias3d[static_cast<std::size_t>(f)];
      const double dist = cv::norm(d) * 1000;
      b.err_mm.push_back(dist);
      if (f == 0) {
        b.add(0, 0, 0, dist);
        continue;
      }
      const cv::Vec3d ax = cv::normalize(w - a);
      cv::Vec3d fw = (t - w) - (t - w).dot(ax) * ax;
      const double fl = cv::norm(fw);
      fw = fl > 1e-9 ? fw / fl : cv::Vec3d(0, 0, 0);
      const double along = d.dot(ax) * 1000, forward = d.dot(fw) * 1000;
      const double rest = cv::norm(d - d.dot(ax) * ax - d.dot(fw) * fw) * 1000;
      if (f <= 2)
        b.add(along, cv::norm(d - d.dot(ax) * ax) * 1000, 0, dist);  // hands: the toe axis is the hand's own
      else
        b.add(along, rest, forward, dist);
    }
  }
  return res;
}

}  // namespace vc::track::eval
