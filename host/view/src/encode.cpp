#include "voxcap/view/encode.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include <nlohmann/json.hpp>

#include "voxcap/config/rig_config.hpp"

namespace vc::view {
namespace {

static_assert(std::endian::native == std::endian::little, "the viewer's messages are written little-endian");

// Appends little-endian values to a message.
class Writer {
 public:
  explicit Writer(MsgType type, size_t reserve = 64) {
    s_.reserve(reserve);
    u8(static_cast<uint8_t>(type));
    u8(kProtocolVersion);
    u16(0);
  }
  template <class T>
  void put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s_.append(b, sizeof(T));
  }
  void u8(uint8_t v) { put(v); }
  void u16(uint16_t v) { put(v); }
  void u32(uint32_t v) { put(v); }
  void u64(uint64_t v) { put(v); }
  void f32(double v) { put(static_cast<float>(v)); }
  void bytes(const uint8_t* p, size_t n) { s_.append(reinterpret_cast<const char*>(p), n); }
  std::string take() { return std::move(s_); }

 private:
  std::string s_;
};

// The 14 bones of the 15-joint skeleton (pipeline::PoseJoint), as joint index pairs.
constexpr int kBones[][2] = {{0, 1}, {1, 2}, {1, 3},  {3, 4},   {4, 5},  {1, 6},   {6, 7},
                             {7, 8}, {0, 9}, {9, 10}, {10, 11}, {0, 12}, {12, 13}, {13, 14}};

const char* const kFeatureNames[] = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};

}  // namespace

int rig_camera_index(const config::RigConfig& rig, uint16_t node_id, uint16_t cam) {
  for (const config::NodeConfig& n : rig.nodes) {
    if (!n.number || *n.number != node_id) continue;
    if (cam >= n.cameras.size()) return -1;
    return rig.camera_index(n.cameras[cam]);
  }
  return -1;
}

std::string encode_hull(const pipeline::Frame& f) {
  const size_t n = f.merged ? std::min(f.rle.size(), kMaxHullRle) : 0;
  Writer w(MsgType::Hull, 48 + n);
  w.u64(f.seq);
  w.u64(f.t_trigger_ns);
  w.u32(f.grid_id);
  uint8_t flags = 0;
  if (f.merged && n == f.rle.size()) flags |= 1;  // the hull is present (complete)
  if (f.degraded) flags |= 2;
  w.u8(flags);
  w.u8(static_cast<uint8_t>(std::min<size_t>(f.present.size(), 255)));
  w.u8(static_cast<uint8_t>(std::min<size_t>(f.missing.size(), 255)));
  w.u8(0);
  w.u64(f.voxel_count);
  w.u64(f.merged ? f.occupied : 0);
  w.f32(f.t_merged_ns > f.t_trigger_ns ? double(f.t_merged_ns - f.t_trigger_ns) / 1e6 : 0.0);
  w.u32(static_cast<uint32_t>((flags & 1) ? n : 0));
  if (flags & 1) w.bytes(f.rle.data(), n);
  return w.take();
}

std::string encode_pose(const pipeline::Frame& f) {
  if (!f.pose.valid()) return {};
  Writer w(MsgType::Pose, 32 + 12 * pipeline::kPoseJointCount);
  w.u64(f.seq);
  w.u8(static_cast<uint8_t>(f.pose.state));
  w.u8(pipeline::kPoseJointCount);
  w.u16(0);
  w.f32(f.pose.confidence);
  w.u32(f.pose.body_version);
  for (const auto& p : f.pose.p_world)
    for (double c : p) w.f32(c);
  return w.take();
}

std::string encode_features3d(const pipeline::Frame& f) {
  if (!f.triangulated) return {};
  const size_t n = std::min<size_t>(f.features3d.size(), 255);
  Writer w(MsgType::Features3D, 16 + 20 * n);
  w.u64(f.seq);
  w.u8(static_cast<uint8_t>(n));
  w.u8(0);
  w.u16(0);
  for (size_t i = 0; i < n; i++) {
    const pipeline::Feature3D& p = f.features3d[i];
    w.u8(static_cast<uint8_t>(std::min<uint16_t>(p.feature_id, 255)));
    w.u8(static_cast<uint8_t>(p.state));
    w.u8(static_cast<uint8_t>(std::min<size_t>(p.views.size(), 255)));
    w.u8(0);
    w.f32(p.confidence);
    for (double c : p.p_world) w.f32(c);
  }
  return w.take();
}

std::string encode_features2d(const pipeline::Frame& f, const config::RigConfig* rig) {
  size_t entries = 0;
  for (const pipeline::NodePart& p : f.nodes) entries += p.features.size();
  entries = std::min(entries, kMaxFeatureCameras);
  Writer w(MsgType::Features2D, 16 + entries * (8 + 16 * 5));
  w.u64(f.seq);
  w.u8(static_cast<uint8_t>(entries));
  w.u8(0);
  w.u16(0);
  size_t written = 0;
  for (const pipeline::NodePart& p : f.nodes) {
    for (const vc_features& fs : p.features) {
      if (written == entries) break;
      written++;
      const int cam = rig ? rig_camera_index(*rig, p.node_id, fs.camera) : -1;
      const size_t n = std::min<size_t>(fs.feature_count, VC_PROTO_MAX_FEATURES);
      w.u16(p.node_id);
      w.u16(static_cast<uint16_t>(fs.camera));
      w.u16(cam < 0 ? 0xFFFF : static_cast<uint16_t>(cam));
      w.u8(static_cast<uint8_t>(n));
      w.u8(0);
      for (size_t i = 0; i < n; i++) {
        const vc_feature& ft = fs.features[i];
        w.u8(static_cast<uint8_t>(std::min<uint16_t>(ft.feature_id, 255)));
        w.u8(static_cast<uint8_t>(std::min<uint16_t>(ft.state, 255)));
        w.u16(0);
        w.f32(ft.u);
        w.f32(ft.v);
        w.f32(ft.confidence);
      }
    }
  }
  return w.take();
}

std::string encode_silhouette(const pipeline::Frame& f, const pipeline::NodePart& part,
                              const pipeline::Silhouette& s, const config::RigConfig* rig) {
  const bool fits = s.rle.size() <= kMaxSilhouetteRle;
  Writer w(MsgType::Silhouette, 32 + (fits ? s.rle.size() : 0));
  const int cam = rig ? rig_camera_index(*rig, part.node_id, s.camera) : -1;
  w.u64(f.seq);
  w.u16(part.node_id);
  w.u16(s.camera);
  w.u16(cam < 0 ? 0xFFFF : static_cast<uint16_t>(cam));
  w.u16(s.scale);
  w.u16(s.width);
  w.u16(s.height);
  w.u32(static_cast<uint32_t>(fits ? s.rle.size() : 0));
  if (fits) w.bytes(s.rle.data(), s.rle.size());
  return w.take();
}

std::string encode_json(MsgType type, std::string_view json) {
  Writer w(type, 4 + json.size());
  w.bytes(reinterpret_cast<const uint8_t*>(json.data()), json.size());
  return w.take();
}

std::string hello_json(const config::RigConfig& rig, std::string_view mode) {
  using nlohmann::json;
  json j;
  j["protocol"] = kProtocolVersion;
  j["rig"] = rig.name;
  j["mode"] = mode;
  j["grid"] = {{"nx", rig.grid.nx},
               {"ny", rig.grid.ny},
               {"nz", rig.grid.nz},
               {"voxel_m", rig.grid.voxel_m},
               {"min_m", {rig.grid.min_m[0], rig.grid.min_m[1], rig.grid.min_m[2]}}};
  json cams = json::array();
  for (size_t c = 0; c < rig.calibration.cameras.size(); c++) {
    const rig::Camera& cam = rig.calibration.cameras[c];
    json R = json::array(), K = json::array();
    for (int r = 0; r < 3; r++)
      for (int k = 0; k < 3; k++) {
        R.push_back(cam.R_cam_from_world(r, k));
        K.push_back(cam.K(r, k));
      }
    std::string node;
    for (const config::NodeConfig& n : rig.nodes)
      for (const std::string& name : n.cameras)
        if (rig.camera_index(name) == static_cast<int>(c)) node = n.id;
    cams.push_back(
        {{"index", c},
         {"name", cam.name},
         {"node", node},
         {"width", cam.width},
         {"height", cam.height},
         {"K", K},
         {"R_cam_from_world", R},
         {"t_cam_from_world", {cam.t_cam_from_world[0], cam.t_cam_from_world[1], cam.t_cam_from_world[2]}}});
  }
  j["cameras"] = cams;
  json nodes = json::array();
  for (const config::NodeConfig& n : rig.nodes)
    nodes.push_back({{"id", n.id},
                     {"number", n.number ? json(*n.number) : json(nullptr)},
                     {"cameras", n.cameras},
                     {"role", std::string(config::to_string(n.role))}});
  j["nodes"] = nodes;
  json joints = json::array();
  for (int i = 0; i < pipeline::kPoseJointCount; i++) joints.push_back(pipeline::pose_joint_name(i));
  j["joints"] = joints;
  json bones = json::array();
  for (const auto& b : kBones) bones.push_back({b[0], b[1]});
  j["bones"] = bones;
  j["features"] = kFeatureNames;
  return j.dump();
}

std::string pose_json(const pipeline::Frame& f) {
  if (!f.pose.valid()) return {};
  nlohmann::json j;
  j["seq"] = f.seq;
  j["t_trigger_ns"] = f.t_trigger_ns;
  j["state"] = pipeline::pose_state_name(f.pose.state);
  j["confidence"] = f.pose.confidence;
  j["body_version"] = f.pose.body_version;
  nlohmann::json joints = nlohmann::json::object();
  for (int i = 0; i < pipeline::kPoseJointCount; i++) {
    const auto& p = f.pose.p_world[static_cast<size_t>(i)];
    joints[pipeline::pose_joint_name(i)] = {p[0], p[1], p[2]};
  }
  j["joints"] = joints;
  return j.dump();
}

}  // namespace vc::view
