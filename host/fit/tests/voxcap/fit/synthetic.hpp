// Synthetic fitter inputs from hw/sim's truth (header-only, target vc_host_fit_testing, which links
// vc_sim; never part of vc_host_fit): a frame's merged hull is the true occupancy of the body on the
// grid, its 3D features the true head centre, wrists and ankles with Gaussian noise, as the
// triangulation stage would report them; and the true pose's 15 joints to score a fit against.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "voxcap/body/joints.hpp"
#include "voxcap/pipeline/frame.hpp"
#include "voxcap/rig/voxel_grid.hpp"
#include "voxcap/rle.h"
#include "voxcap/sim/scene.hpp"

namespace vc::fit::testing {

struct FeatureNoise {
  double sigma_m = 0.01;    // Gaussian noise per axis on every feature
  float confidence = 0.8f;  // reported confidence
  // Feature `drop_feature` (vc_feature_id) is reported too_few_views on frames [drop_from, drop_to).
  int drop_feature = -1;
  int drop_from = 0, drop_to = 0;
};

// The merged frame `frame` of `scene` on `grid`: true occupancy as the hull, noisy true features.
inline pipeline::Frame synthetic_frame(const sim::Scene& scene, const rig::VoxelGrid& grid, int frame,
                                       const FeatureNoise& noise, std::mt19937_64& rng) {
  pipeline::Frame f;
  f.seq = static_cast<uint64_t>(frame);
  std::vector<uint8_t> bits;
  scene.occupancy(grid, frame, &bits);
  f.rle.resize(vc_rle_max_encoded_size(grid.count()));
  size_t len = 0;
  if (vc_rle_encode(bits.data(), grid.count(), f.rle.data(), f.rle.size(), &len) != 0)
    throw std::runtime_error("synthetic_frame: RLE encoding failed");
  f.rle.resize(len);
  f.merged = true;
  f.voxel_count = grid.count();
  const auto joints = scene.joints(frame);
  std::normal_distribution<double> n01(0, 1);
  for (int i = 0; i < body::kFeatureCount; ++i) {
    pipeline::Feature3D ft;
    ft.feature_id = static_cast<uint16_t>(i);
    const cv::Vec3d p = joints[static_cast<size_t>(body::feature_joint(static_cast<body::Feature>(i)))];
    for (int c = 0; c < 3; ++c) ft.p_world[static_cast<size_t>(c)] = p[c] + noise.sigma_m * n01(rng);
    ft.state = pipeline::Feature3DState::Triangulated;
    ft.confidence = noise.confidence;
    if (i == noise.drop_feature && frame >= noise.drop_from && frame < noise.drop_to) {
      ft.state = pipeline::Feature3DState::TooFewViews;
      ft.confidence = 0;
    }
    f.features3d.push_back(ft);
  }
  f.triangulated = true;
  return f;
}

// The true positions of the 15 pose joints (PoseJoint order) at `frame`.
inline std::array<cv::Vec3d, pipeline::kPoseJointCount> true_pose(const sim::Scene& scene, int frame) {
  const auto joints = scene.joints(frame);
  std::array<cv::Vec3d, pipeline::kPoseJointCount> out;
  for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
    const int k = body::joint_from_name(pipeline::pose_joint_name(j));
    if (k < 0) throw std::logic_error("true_pose: a pose joint with no standard joint");
    out[static_cast<size_t>(j)] = joints[static_cast<size_t>(k)];
  }
  return out;
}

// Mean per-joint position error of a pose against the truth (metres).
inline double mpjpe(const pipeline::Pose& pose,
                    const std::array<cv::Vec3d, pipeline::kPoseJointCount>& truth) {
  double sum = 0;
  for (size_t j = 0; j < truth.size(); ++j) {
    const auto& p = pose.p_world[j];
    sum += cv::norm(cv::Vec3d(p[0], p[1], p[2]) - truth[j]);
  }
  return sum / static_cast<double>(truth.size());
}

}  // namespace vc::fit::testing
