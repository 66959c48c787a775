// Synthetic fitter inputs from hw/sim's truth (header-only, target vc_host_fit_testing, which links
// vc_sim; never part of vc_host_fit): a frame's merged hull is the true occupancy of the body on the
// grid, its 3D features the true head centre, wrists and ankles with Gaussian noise, as the
// triangulation stage would report them; and the true pose's 15 joints to score a fit against.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
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
    const cv::Vec3d& p = joints[static_cast<size_t>(body::feature_joint(static_cast<body::Feature>(i)))];
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

// A visual hull like the rig's: the centre of every voxel near the body carved against hw/sim's true
// silhouettes of every camera of the scene (the method's rule: inside all of them), so with the
// phantom volumes that few views leave. Voxels further than margin_m from the true body's box are
// left empty (they would be carved away with silhouettes of the body alone anyway, but for a rare
// aligned ghost). `masks` is reused between calls.
inline std::vector<uint8_t> carved_hull(const sim::Scene& scene, const rig::VoxelGrid& grid, int frame,
                                        std::vector<cv::Mat>* masks, double margin_m = 0.3) {
  const rig::Calibration& cal = scene.calibration();
  masks->resize(cal.cameras.size());
  cv::Mat rgb;
  for (size_t c = 0; c < cal.cameras.size(); ++c)
    scene.render_clean(frame, static_cast<int>(c), rgb, &(*masks)[c]);
  // The box: the true body's, grown by the margin.
  std::vector<uint8_t> truth;
  scene.occupancy(grid, frame, &truth);
  int lo[3] = {grid.nx, grid.ny, grid.nz}, hi[3] = {-1, -1, -1};
  for (int k = 0; k < grid.nz; ++k)
    for (int j = 0; j < grid.ny; ++j)
      for (int i = 0; i < grid.nx; ++i)
        if (rig::hull_bit(truth.data(), grid.index(i, j, k))) {
          lo[0] = std::min(lo[0], i), lo[1] = std::min(lo[1], j), lo[2] = std::min(lo[2], k);
          hi[0] = std::max(hi[0], i), hi[1] = std::max(hi[1], j), hi[2] = std::max(hi[2], k);
        }
  std::vector<uint8_t> bits(grid.bitset_bytes(), 0);
  if (hi[0] < 0) return bits;
  const int m = static_cast<int>(std::ceil(margin_m / grid.voxel_m));
  const int dims[3] = {grid.nx, grid.ny, grid.nz};
  for (int a = 0; a < 3; ++a) lo[a] = std::max(0, lo[a] - m), hi[a] = std::min(dims[a] - 1, hi[a] + m);
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i) {
        const cv::Vec3d p = grid.center(i, j, k);
        bool in = true;
        for (size_t c = 0; c < cal.cameras.size() && in; ++c) {
          const rig::Camera& cam = cal.cameras[c];
          if (cam.to_cam(p)[2] <= 0) {
            in = false;
            break;
          }
          const cv::Point2d px = cam.project(p);
          const int u = static_cast<int>(std::lround(px.x)), v = static_cast<int>(std::lround(px.y));
          // Outside the image: no evidence against it (the camera does not see it).
          if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
          in = (*masks)[c].at<uint8_t>(v, u) != 0;
        }
        if (in) rig::hull_set(bits.data(), grid.index(i, j, k));
      }
  return bits;
}

// The same frame as synthetic_frame with the carved hull in place of the true occupancy.
inline pipeline::Frame carved_frame(const sim::Scene& scene, const rig::VoxelGrid& grid, int frame,
                                    const FeatureNoise& noise, std::mt19937_64& rng,
                                    std::vector<cv::Mat>* masks) {
  pipeline::Frame f = synthetic_frame(scene, grid, frame, noise, rng);
  const std::vector<uint8_t> bits = carved_hull(scene, grid, frame, masks);
  f.rle.assign(vc_rle_max_encoded_size(grid.count()), 0);
  size_t len = 0;
  if (vc_rle_encode(bits.data(), grid.count(), f.rle.data(), f.rle.size(), &len) != 0)
    throw std::runtime_error("carved_frame: RLE encoding failed");
  f.rle.resize(len);
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

// A pose joint's position, as cv::Vec3d (fitted pose or truth).
inline cv::Vec3d joint(const pipeline::Pose& p, pipeline::PoseJoint j) {
  const auto& v = p.p_world[static_cast<size_t>(j)];
  return {v[0], v[1], v[2]};
}
inline cv::Vec3d joint(const std::array<cv::Vec3d, pipeline::kPoseJointCount>& t, pipeline::PoseJoint j) {
  return t[static_cast<size_t>(j)];
}

// The 3D feature `id` (vc_feature_id) of a frame, to edit (a test's fault injection); nullptr if absent.
inline pipeline::Feature3D* feature(pipeline::Frame* f, int id) {
  for (pipeline::Feature3D& ft : f->features3d)
    if (ft.feature_id == id) return &ft;
  return nullptr;
}
inline cv::Vec3d position(const pipeline::Feature3D& ft) {
  return {ft.p_world[0], ft.p_world[1], ft.p_world[2]};
}
inline void set_position(pipeline::Feature3D* ft, const cv::Vec3d& p) {
  for (size_t c = 0; c < 3; ++c) ft->p_world[c] = p[static_cast<int>(c)];
}

// A hull bitset of `grid` as a merged frame's RLE (a test's own hull in a frame).
inline std::vector<uint8_t> encode_hull(const rig::VoxelGrid& grid, const std::vector<uint8_t>& bits) {
  std::vector<uint8_t> rle(vc_rle_max_encoded_size(grid.count()));
  size_t len = 0;
  if (vc_rle_encode(bits.data(), grid.count(), rle.data(), rle.size(), &len) != 0)
    throw std::runtime_error("encode_hull: RLE encoding failed");
  rle.resize(len);
  return rle;
}

// One motion of hw/sim (a built-in name or a BVH file) on its default rig and grid, with the features'
// noise generator: what the fit tests start from. Frames are generated in any order, each from the
// one generator (so a take's noise depends on the order frames are asked for, as the tests' did).
class SyntheticTake {
 public:
  explicit SyntheticTake(const std::string& motion, uint64_t seed, sim::SceneOptions options = {})
      : scene_(with_motion(std::move(options), motion)), grid_(*scene_.calibration().grid), rng_(seed) {}

  const sim::Scene& scene() const { return scene_; }
  const rig::VoxelGrid& grid() const { return grid_; }
  int lead_in() const { return scene_.motion().lead_in_frames(); }
  int frames() const { return scene_.motion().natural_frames(); }  // lead-in + one cycle (or the clip)

  // Frame `i`: true occupancy as the hull, noisy true features (synthetic_frame).
  pipeline::Frame frame(int i, const FeatureNoise& noise = {}) {
    return synthetic_frame(scene_, grid_, i, noise, rng_);
  }
  // Frame `i` with the hull carved from the true silhouettes of the rig's cameras (carved_frame).
  pipeline::Frame carved_frame(int i, const FeatureNoise& noise, std::vector<cv::Mat>* masks) {
    return testing::carved_frame(scene_, grid_, i, noise, rng_, masks);
  }
  std::array<cv::Vec3d, pipeline::kPoseJointCount> truth(int i) const { return true_pose(scene_, i); }

 private:
  static sim::SceneOptions with_motion(sim::SceneOptions o, const std::string& motion) {
    o.motion.source = motion;
    return o;
  }
  sim::Scene scene_;
  rig::VoxelGrid grid_;
  std::mt19937_64 rng_;
};

}  // namespace vc::fit::testing
