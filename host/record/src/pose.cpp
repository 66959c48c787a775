#include "voxcap/record/pose.hpp"

#include <cmath>

#include <fmt/format.h>

namespace vc::record {

void to_record(uint64_t seq, const pipeline::Pose& pose, bool with_names, PoseRecord* out) {
  out->seq = seq;
  out->layout.assign(kPoseLayout);
  out->joint_names.resize(with_names ? pipeline::kPoseJointCount : 0);
  for (size_t j = 0; j < out->joint_names.size(); ++j)
    out->joint_names[j].assign(pipeline::pose_joint_name(static_cast<int>(j)));
  out->values.resize(kPoseValues);
  double* v = out->values.data();
  v[0] = static_cast<double>(static_cast<uint8_t>(pose.state));
  v[1] = static_cast<double>(pose.body_version);
  v[2] = static_cast<double>(pose.confidence);
  v[3] = static_cast<double>(pose.t_fitted_ns >> 32);
  v[4] = static_cast<double>(pose.t_fitted_ns & 0xFFFFFFFFu);
  for (size_t i = 0; i < 9; ++i) v[5 + i] = pose.torso_R_world[i];
  for (size_t j = 0; j < static_cast<size_t>(pipeline::kPoseJointCount); ++j)
    for (size_t a = 0; a < 3; ++a) v[14 + 3 * j + a] = pose.p_world[j][a];
}

namespace {

bool fail(std::string* why, std::string msg) {
  if (why) *why = std::move(msg);
  return false;
}

// An integer in [0, max] held exactly by a double.
bool integral(double x, double max) {
  return std::isfinite(x) && x >= 0 && x <= max && std::floor(x) == x;
}

}  // namespace

bool from_record(const PoseRecord& r, pipeline::Pose* out, std::string* why) {
  if (r.layout != kPoseLayout)
    return fail(why, fmt::format("pose seq {}: layout \"{}\" is not \"{}\"", r.seq, r.layout, kPoseLayout));
  if (r.values.size() != kPoseValues)
    return fail(why, fmt::format("pose seq {}: {} values, layout {} has {}", r.seq, r.values.size(),
                                 kPoseLayout, kPoseValues));
  if (!r.joint_names.empty()) {
    if (r.joint_names.size() != static_cast<size_t>(pipeline::kPoseJointCount))
      return fail(why, fmt::format("pose seq {}: {} joint names, layout {} has {}", r.seq,
                                   r.joint_names.size(), kPoseLayout, pipeline::kPoseJointCount));
    for (size_t j = 0; j < r.joint_names.size(); ++j)
      if (r.joint_names[j] != pipeline::pose_joint_name(static_cast<int>(j)))
        return fail(why, fmt::format("pose seq {}: joint {} is \"{}\", not \"{}\"", r.seq, j,
                                     r.joint_names[j], pipeline::pose_joint_name(static_cast<int>(j))));
  }
  const double* v = r.values.data();
  for (size_t i = 0; i < kPoseValues; ++i)
    if (!std::isfinite(v[i])) return fail(why, fmt::format("pose seq {}: value {} is not finite", r.seq, i));
  if (!integral(v[0], 3)) return fail(why, fmt::format("pose seq {}: state {} is not 0..3", r.seq, v[0]));
  if (!integral(v[1], 4294967295.0))
    return fail(why, fmt::format("pose seq {}: body_version {} is not a u32", r.seq, v[1]));
  if (!integral(v[3], 4294967295.0) || !integral(v[4], 4294967295.0))
    return fail(why, fmt::format("pose seq {}: t_fitted_ns halves are not u32", r.seq));
  out->state = static_cast<pipeline::PoseState>(static_cast<uint8_t>(v[0]));
  out->body_version = static_cast<uint32_t>(v[1]);
  out->confidence = static_cast<float>(v[2]);
  out->t_fitted_ns = (static_cast<uint64_t>(v[3]) << 32) | static_cast<uint64_t>(v[4]);
  for (size_t i = 0; i < 9; ++i) out->torso_R_world[i] = v[5 + i];
  for (size_t j = 0; j < static_cast<size_t>(pipeline::kPoseJointCount); ++j)
    for (size_t a = 0; a < 3; ++a) out->p_world[j][a] = v[14 + 3 * j + a];
  return true;
}

pipeline::Frame frame_from_record(const FrameRecord& record) {
  pipeline::Frame f;
  f.seq = record.seq;
  f.t_trigger_ns = record.t_trigger_ns;
  f.t_merged_ns = record.t_merged_ns;
  f.grid_id = record.grid_id;
  f.voxel_count = record.voxel_count;
  f.occupied = record.occupied;
  f.degraded = record.degraded;
  f.present = record.nodes_present;
  f.missing = record.nodes_missing;
  f.rle = record.rle;
  f.merged = !record.rle.empty();
  return f;
}

void to_record(const pipeline::Feature3D& feature, Features3DRecord::P* out) {
  out->id = feature.feature_id;
  out->state = static_cast<uint8_t>(feature.state);
  out->x = feature.p_world[0];
  out->y = feature.p_world[1];
  out->z = feature.p_world[2];
  out->confidence = feature.confidence;
  out->reproj_px = feature.reproj_px;
  out->name_trusted = feature.name_trusted;
  out->views.assign(feature.views.begin(), feature.views.end());
}

pipeline::Feature3D feature3d_from_record(const Features3DRecord::P& record) {
  pipeline::Feature3D f;
  f.feature_id = record.id;
  f.state = record.state < pipeline::kFeature3DStateCount
                ? static_cast<pipeline::Feature3DState>(record.state)
                : pipeline::Feature3DState::Inconsistent;
  f.p_world = {record.x, record.y, record.z};
  f.confidence = record.confidence;
  f.reproj_px = record.reproj_px;
  f.name_trusted = record.name_trusted;
  f.views = record.views;
  return f;
}

}  // namespace vc::record
