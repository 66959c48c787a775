// Synthetic edge observations for the triangulation tests and benchmark (header-only, target
// vc_host_triangulate_testing, which links vc_sim; not part of vc_host_triangulate): hw/sim's true 2D
// features (the projections of the true head centre, wrists and ankles, with occlusion) turned into what an
// edge would send — pixel noise, outliers at full confidence, lost features, and hands/feet labelled by image
// side (the edge's "left" is the one further right in its image, as if each camera faced the performer).
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "voxcap/proto.h"
#include "voxcap/sim/scene.hpp"
#include "voxcap/triangulate/triangulate.hpp"

namespace vc::triangulate::testing {

struct Noise {
  double sigma_px = 1.0;   // Gaussian pixel noise
  double outlier = 0.0;    // probability that a visible feature is reported 25..150 px off, confident
  double lost = 0.0;       // probability that a visible feature is reported lost
  double predicted = 0.0;  // probability that it is reported predicted (2 px more noise)
  double swap = 0.0;       // probability that a camera swaps a pair's labels on top of the image side
};

// The edges' observations of frame `frame` of `scene`, every camera of its calibration.
inline std::vector<CameraObservations> observe(const sim::Scene& scene, int frame, const Noise& noise,
                                               std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<CameraObservations> out;
  for (int c = 0; c < scene.camera_count(); ++c) {
    const std::vector<sim::FeatureTruth> truth = scene.features(frame, c);
    CameraObservations co;
    co.camera = c;
    std::array<Observation, 5> by_truth{};
    for (const sim::FeatureTruth& t : truth) {
      Observation o;
      o.present = true;
      if (!t.visible) {
        o.state = VC_FEATURE_NOT_VISIBLE;
      } else {
        o.state = VC_FEATURE_TRACKING;
        o.confidence = 0.6 + 0.4 * u01(rng);
        double s = noise.sigma_px;
        if (u01(rng) < noise.predicted) {
          o.state = VC_FEATURE_PREDICTED;
          s += 2;
        }
        // Draws in separate statements: the order of a call's arguments is unspecified (gcc evaluates
        // them right to left, clang left to right), which gave the two builds different noise.
        const double nx = n01(rng);
        const double ny = n01(rng);
        o.uv_px = t.uv + cv::Point2d(s * nx, s * ny);
        if (u01(rng) < noise.outlier) {
          const double r = 25 + 125 * u01(rng), a = 6.283185307 * u01(rng);
          o.uv_px += cv::Point2d(r * std::cos(a), r * std::sin(a));
          o.state = VC_FEATURE_TRACKING;
          o.confidence = 0.9;
        }
        if (u01(rng) < noise.lost) o.state = VC_FEATURE_LOST;
      }
      by_truth[static_cast<size_t>(t.feature)] = o;
    }
    co.features[VC_FEATURE_HEAD] = by_truth[0];
    // Label each pair by image side: the edge's left is the one with the larger u.
    for (size_t first : {size_t{VC_FEATURE_LEFT_HAND}, size_t{VC_FEATURE_LEFT_FOOT}}) {
      Observation a = by_truth[first], b = by_truth[first + 1];
      const bool va = a.state != VC_FEATURE_NOT_VISIBLE, vb = b.state != VC_FEATURE_NOT_VISIBLE;
      if ((va && vb && b.uv_px.x > a.uv_px.x) || (!va && vb)) std::swap(a, b);
      if (u01(rng) < noise.swap) std::swap(a, b);
      co.features[first] = a;
      co.features[first + 1] = b;
    }
    out.push_back(co);
  }
  return out;
}

// The true 3D position of feature id `f` (vc_feature_id) at `frame`.
inline cv::Vec3d truth(const sim::Scene& scene, int frame, int f) {
  return scene.joints(frame)[static_cast<size_t>(body::feature_joint(static_cast<body::Feature>(f)))];
}

}  // namespace vc::triangulate::testing
