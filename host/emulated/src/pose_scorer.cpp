// The pose scorer: every frame's fitted skeleton against hw/sim's true joints (rules in
// pose_scorer.hpp).
#include "voxcap/emulated/pose_scorer.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "voxcap/body/joints.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::emulated {
namespace {

constexpr int kJ = pipeline::kPoseJointCount;

// hw/body's standard joint of each PoseJoint (the same names).
const std::array<int, kJ>& standard_of() {
  static const std::array<int, kJ> m = [] {
    std::array<int, kJ> a{};
    for (int j = 0; j < kJ; ++j)
      a[static_cast<size_t>(j)] = body::joint_from_name(pipeline::pose_joint_name(j));
    return a;
  }();
  return m;
}

}  // namespace

PoseScorer::PoseScorer(std::unique_ptr<sim::Scene> scene, const rig::VoxelGrid& grid, bool keep_poses)
    : scene_(std::move(scene)), grid_(grid), keep_poses_(keep_poses) {}

PoseScorer::~PoseScorer() = default;

void PoseScorer::configure(const pipeline::StageContext& ctx) {
  std::lock_guard<std::mutex> g(mu_);
  timing_.set_chain(ctx.chain);
}

void PoseScorer::set_origin(uint64_t origin) {
  origin_ = origin;
  started_ = true;
}

void PoseScorer::joint_errors(const pipeline::Pose& pose, const std::array<std::array<double, 3>, kJ>& truth,
                              std::array<double, kJ>* err_m, double* pa_mean_m) {
  cv::Vec3d mf(0, 0, 0), mt(0, 0, 0);
  for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) {
    const cv::Vec3d f(pose.p_world[j][0], pose.p_world[j][1], pose.p_world[j][2]);
    const cv::Vec3d t(truth[j][0], truth[j][1], truth[j][2]);
    (*err_m)[j] = cv::norm(f - t);
    mf += f;
    mt += t;
  }
  mf *= 1.0 / kJ;
  mt *= 1.0 / kJ;
  // Procrustes with scale (Umeyama): R, s minimising sum |s R (f - mf) - (t - mt)|^2.
  cv::Matx33d H = cv::Matx33d::zeros();
  double var_f = 0;
  for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) {
    const cv::Vec3d f = cv::Vec3d(pose.p_world[j][0], pose.p_world[j][1], pose.p_world[j][2]) - mf;
    const cv::Vec3d t = cv::Vec3d(truth[j][0], truth[j][1], truth[j][2]) - mt;
    H += t * f.t();
    var_f += f.dot(f);
  }
  cv::Matx33d U, Vt;
  cv::Matx31d S;
  cv::SVD::compute(H, S, U, Vt);
  cv::Matx33d D = cv::Matx33d::eye();
  if (cv::determinant(U * Vt) < 0) D(2, 2) = -1;
  const cv::Matx33d R = U * D * Vt;
  const double s = var_f > 0 ? (S(0) * D(0, 0) + S(1) * D(1, 1) + S(2) * D(2, 2)) / var_f : 1.0;
  double pa = 0;
  for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) {
    const cv::Vec3d f = cv::Vec3d(pose.p_world[j][0], pose.p_world[j][1], pose.p_world[j][2]) - mf;
    const cv::Vec3d t(truth[j][0], truth[j][1], truth[j][2]);
    pa += cv::norm(s * (R * f) + mt - t);
  }
  *pa_mean_m = pa / kJ;
}

void PoseScorer::process(pipeline::Frame& f) {
  const uint64_t origin = origin_;
  if (!started_ || f.seq < origin) return;
  const int frame = static_cast<int>(f.seq - origin);
  const pipeline::Pose& pose = f.pose;
  std::lock_guard<std::mutex> g(mu_);
  acc_.merged_frames++;
  if (keep_poses_) acc_.poses.push_back({frame, pose});
  if (!pose.valid()) {
    if (seen_pose_)
      acc_.frames++;
    else
      acc_.init_frames++;
    return;
  }
  seen_pose_ = true;
  acc_.frames++;
  acc_.fitted_frames++;
  acc_.predicted_frames += pose.state == pipeline::PoseState::Predicted ? 1 : 0;
  acc_.reinitialized_frames += pose.state == pipeline::PoseState::Reinitialized ? 1 : 0;
  if (pose.t_fitted_ns >= f.t_trigger_ns && f.t_trigger_ns > 0) {
    latency_.add(pose.t_fitted_ns - f.t_trigger_ns);
    timing_.add(f);
  }
  if (t_first_ns_ == 0) t_first_ns_ = pose.t_fitted_ns;
  t_last_ns_ = pose.t_fitted_ns;

  const std::array<cv::Vec3d, body::kJointCount> truth = scene_->joints(frame);
  // An arm inside the torso: a fitted elbow or wrist inside the true torso volume.
  const std::vector<sim::Primitive> prims = scene_->primitives(frame);
  bool arm_in_torso = false;
  for (pipeline::PoseJoint j : {pipeline::PoseJoint::l_elbow, pipeline::PoseJoint::l_wrist,
                                pipeline::PoseJoint::r_elbow, pipeline::PoseJoint::r_wrist}) {
    const auto& q = pose.p_world[static_cast<size_t>(j)];
    for (const sim::Primitive& p : prims)
      if (sim::part_group(static_cast<int>(p.part)) == 1 /* torso */ && p.contains({q[0], q[1], q[2]}))
        arm_in_torso = true;
  }
  acc_.arm_in_torso_frames += arm_in_torso ? 1 : 0;
  // Part of the body outside the capture volume: a true joint outside the grid's box.
  const cv::Vec3d lo = grid_.min_m;
  const cv::Vec3d hi = lo + cv::Vec3d(grid_.nx, grid_.ny, grid_.nz) * grid_.voxel_m;
  for (const cv::Vec3d& p : truth)
    for (int a = 0; a < 3; ++a)
      if (p[a] < lo[a] || p[a] > hi[a]) {
        acc_.frames_outside_volume++;
        return;
      }
  std::array<std::array<double, 3>, kJ> t{};
  for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) {
    const cv::Vec3d& v = truth[static_cast<size_t>(standard_of()[j])];
    t[j] = {v[0], v[1], v[2]};
  }
  std::array<double, kJ> err{};
  double pa = 0;
  joint_errors(pose, t, &err, &pa);
  double mean = 0;
  for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) {
    sum_joint_[j] += err[j];
    mean += err[j];
    acc_.max_joint_mm = std::max(acc_.max_joint_mm, 1e3 * err[j]);
  }
  sum_mpjpe_ += mean / kJ;
  sum_pa_ += pa;
  acc_.scored_frames++;
}

PoseAccuracy PoseScorer::accuracy() const {
  std::lock_guard<std::mutex> g(mu_);
  PoseAccuracy a = acc_;
  const double n = double(acc_.scored_frames);
  if (n > 0) {
    a.mpjpe_mm = 1e3 * sum_mpjpe_ / n;
    a.pa_mpjpe_mm = 1e3 * sum_pa_ / n;
    for (size_t j = 0; j < static_cast<size_t>(kJ); ++j) a.per_joint_mm[j] = 1e3 * sum_joint_[j] / n;
  }
  if (acc_.fitted_frames > 1 && t_last_ns_ > t_first_ns_)
    a.fps = double(acc_.fitted_frames - 1) / (double(t_last_ns_ - t_first_ns_) * 1e-9);
  a.latency_p50_ms = latency_.percentile_ms(0.50);
  a.latency_p99_ms = latency_.percentile_ms(0.99);
  a.latency_max_ms = latency_.max_ms();
  a.latency_split = timing_.split();
  if (keep_poses_) a.timing = timing_.rows();
  return a;
}

}  // namespace vc::emulated
