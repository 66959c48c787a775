// The feature scorer: the tracked head, hands and feet of every merged frame against the virtual rig's
// truth (issue #11, "Figures"). A consumer stage of the host's pipeline behind the triangulate stage;
// the simulator's frame of seq is seq − origin (the run's origin, START), as for the truth scorer.
//
// 3D, per feature: the true point is hw/body's feature joint (head centre, wrist, ankle) of
// Scene::joints; the part counts as visible in a frame when at least two cameras see it
// (Scene::features(frame, cam).visible: in the image and not occluded). Over those frames, the error of
// a triangulated Frame::features3d position (p50/p95, mm), the frames without one — before its first
// triangulation (start-up: the edges learn the background and initialize) or after it (lost) — and
// the runs of consecutive lost frames (a frame where fewer than two cameras see the part pauses a run:
// "recovered within N frames of the part being visible again"). In every frame, a triangulated
// position with confidence above the documented threshold that is more than 10 cm from the truth is a
// confident wrong answer.
//
// 2D, per rig camera (node k's camera i is rig camera 2k + i): the edges' FEATURES in state tracking
// against the truth's 2D features (distorted pixels both) while visible. The edges label hands and
// feet by image side (proto/SPEC.md; the host decides the performer's left and right), so each
// camera's reported pair is matched to the true pair by the assignment (kept or swapped) with the
// smaller summed distance; a tracker on the wrong part still shows as a large error when the other
// label is reported too, and as a confident wrong answer in 3D. Visible but not tracking: untracked.
//
// Limits: percentiles come from fixed histograms (0.1 mm and 0.05 px bins; beyond 2 m or 1000 px, the
// largest value seen). Frames the stage's queue dropped (a loaded machine) are not scored (counted as
// the stage's drops in the pipeline report).
#include "feature_scorer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "voxcap/rig/calibration.hpp"

namespace vc::emulated {

void Histogram::add(double x) {
  if (!std::isfinite(x) || x < 0) x = 0;
  const double b = x / bin_;
  const size_t i = b >= double(n_.size() - 1) ? n_.size() - 1 : static_cast<size_t>(b);
  n_[i]++;
  count_++;
  max_ = std::max(max_, x);
}

double Histogram::quantile(double q) const {
  if (count_ == 0) return std::numeric_limits<double>::quiet_NaN();
  // Nearest rank: the smallest value with at least q of the samples at or below it.
  const auto rank = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(q * double(count_))));
  uint64_t seen = 0;
  for (size_t i = 0; i < n_.size(); i++) {
    seen += n_[i];
    if (seen >= rank) return i + 1 == n_.size() ? max_ : std::min(max_, (double(i) + centre_) * bin_);
  }
  return max_;
}

FeatureScorer::FeatureScorer(const Options& opt, const std::string& calibration, double confident)
    : cameras_(2 * opt.nodes), confident_(confident) {
  scene_ = std::make_unique<sim::Scene>(truth_scene_options(opt, rig::read_calibration(calibration)));
  views_.resize(static_cast<size_t>(cameras_));
  truth_.resize(static_cast<size_t>(cameras_));
}

void FeatureScorer::process(pipeline::Frame& f) {
  const uint64_t origin = origin_;
  if (!started_ || f.seq < origin) return;
  frame_ = static_cast<int>(std::min<uint64_t>(f.seq - origin, uint64_t(std::numeric_limits<int>::max())));
  const std::array<cv::Vec3d, sim::kJointCount> joints = scene_->joints(frame_);
  std::array<int, kTrackedFeatures> seen_by{};
  for (int c = 0; c < cameras_; c++) {
    auto& truth = truth_[static_cast<size_t>(c)];
    truth = {};
    for (const sim::FeatureTruth& t : scene_->features(frame_, c)) {
      const auto i = static_cast<size_t>(t.feature);
      if (i >= truth.size()) continue;
      truth[i] = t;
      if (t.visible) seen_by[i]++;
    }
  }

  std::lock_guard<std::mutex> g(mu_);
  frames_++;
  for (size_t i = 0; i < kTrackedFeatures; i++) {
    Sums& m = sums_[i];
    const pipeline::Feature3D* p = nullptr;
    for (const pipeline::Feature3D& q : f.features3d)
      if (q.feature_id == i) p = &q;
    const bool tri = f.triangulated && p && p->state == pipeline::Feature3DState::Triangulated;
    double err_mm = 0;
    if (tri) {
      const cv::Vec3d& truth = joints[static_cast<size_t>(sim::feature_joint(static_cast<sim::Feature>(i)))];
      const cv::Vec3d d(p->p_world[0] - truth[0], p->p_world[1] - truth[1], p->p_world[2] - truth[2]);
      err_mm = 1000 * cv::norm(d);
      if (double(p->confidence) > confident_ && err_mm > 100) m.s.confident_wrong++;
    }
    if (seen_by[i] < 2) {
      if (tri && m.run > 0) m.runs.add(double(m.run)), m.run = 0;  // back, though not seen by two
      continue;
    }
    m.s.frames_visible++;
    if (tri) {
      m.s.frames_triangulated++;
      m.err3d_mm.add(err_mm);
      m.acquired = true;
      if (m.run > 0) m.runs.add(double(m.run)), m.run = 0;
    } else if (m.acquired) {
      m.s.frames_lost++;
      if (m.run++ == 0) m.s.losses++;
    } else {
      m.s.frames_to_acquire++;
    }
  }
  score_2d(f);
}

// The edges' FEATURES of this frame against the truth (mu_ held).
void FeatureScorer::score_2d(const pipeline::Frame& f) {
  for (auto& v : views_) v = {};
  for (const pipeline::NodePart& n : f.nodes)
    for (const vc_features& m : n.features) {
      const int cam = 2 * int(n.node_id) + int(m.camera);
      if (m.camera > 1 || cam >= cameras_) continue;  // not a camera of this rig
      for (size_t k = 0; k < std::min<size_t>(m.feature_count, VC_PROTO_MAX_FEATURES); k++) {
        const vc_feature& x = m.features[k];
        if (x.feature_id >= kTrackedFeatures) continue;
        View& v = views_[static_cast<size_t>(cam)][x.feature_id];
        v = {true, x.state == VC_FEATURE_TRACKING, double(x.u), double(x.v)};
      }
    }
  for (int c = 0; c < cameras_; c++) {
    const auto& truth = truth_[static_cast<size_t>(c)];
    const auto& view = views_[static_cast<size_t>(c)];
    auto dist = [&](size_t e, size_t t) {
      return std::hypot(view[e].u - truth[t].uv.x, view[e].v - truth[t].uv.y);
    };
    // Which reported label scores against which true feature: the head as is, each pair kept or
    // swapped, whichever fits the tracking reports better.
    std::array<size_t, kTrackedFeatures> from = {0, 1, 2, 3, 4};
    for (size_t a : {size_t{1}, size_t{3}}) {
      const size_t b = a + 1;
      double kept = 0, swapped = 0;
      if (view[a].tracking) kept += dist(a, a), swapped += dist(a, b);
      if (view[b].tracking) kept += dist(b, b), swapped += dist(b, a);
      if (swapped < kept) std::swap(from[a], from[b]);
    }
    for (size_t t = 0; t < kTrackedFeatures; t++) {
      if (!truth[t].visible) continue;
      FeatureScore& s = sums_[t].s;
      s.views_visible++;
      const size_t e = from[t];
      if (view[e].tracking)
        sums_[t].err2d_px.add(dist(e, t));
      else
        s.views_untracked++;
    }
  }
}

FeatureAccuracy FeatureScorer::figures() const {
  std::lock_guard<std::mutex> g(mu_);
  FeatureAccuracy a;
  a.frames = frames_;
  a.confident = confident_;
  for (size_t i = 0; i < kTrackedFeatures; i++) {
    const Sums& m = sums_[i];
    FeatureScore s = m.s;
    s.err3d_p50_mm = m.err3d_mm.quantile(0.5);
    s.err3d_p95_mm = m.err3d_mm.quantile(0.95);
    s.err2d_p50_px = m.err2d_px.quantile(0.5);
    s.err2d_p95_px = m.err2d_px.quantile(0.95);
    Histogram runs = m.runs;
    if (m.run > 0) runs.add(double(m.run));  // still lost at the end
    s.recover_max_frames = static_cast<uint64_t>(runs.max());
    s.recover_p95_frames = runs.count() ? runs.quantile(0.95) : 0;
    a.features[i] = s;
  }
  return a;
}

}  // namespace vc::emulated
