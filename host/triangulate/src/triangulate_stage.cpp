#include "voxcap/triangulate/triangulate_stage.hpp"

#include <algorithm>
#include <optional>
#include <stdexcept>

#include "voxcap/config/rig_config.hpp"
#include "voxcap/proto.h"

namespace vc::triangulate {

int rig_camera_of(const config::RigConfig& rig, uint16_t node_id, uint16_t camera) {
  for (const config::NodeConfig& n : rig.nodes) {
    if (!n.number || *n.number != node_id) continue;
    if (camera >= n.cameras.size()) return -1;
    return rig.camera_index(n.cameras[camera]);
  }
  return -1;
}

std::vector<int> front_cameras(const config::RigConfig& rig) {
  std::vector<int> out;
  for (const config::NodeConfig& n : rig.nodes)
    if (n.is_front())
      for (const std::string& c : n.cameras)
        if (int k = rig.camera_index(c); k >= 0) out.push_back(k);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void TriangulateStage::configure(const pipeline::StageContext& ctx) {
  if (!ctx.rig) throw std::invalid_argument("triangulate: no rig configuration");
  const config::RigConfig& rig = *ctx.rig;
  if (rig.calibration.cameras.size() < 2)
    throw std::invalid_argument("triangulate: the calibration has fewer than two cameras");
  nodes_.clear();
  for (const config::NodeConfig& n : rig.nodes) {
    if (!n.number) continue;
    NodeMap m{*n.number, {}};
    for (const std::string& c : n.cameras) m.rig_camera.push_back(rig.camera_index(c));
    nodes_.push_back(std::move(m));
  }
  heading_ = ctx.body_heading;
  grid_ = rig.grid;
  tri_ =
      std::make_unique<FeatureTriangulator>(rig.calibration.cameras, front_cameras(rig), rig.triangulation);
}

void TriangulateStage::process(pipeline::Frame& frame) {
  obs_.clear();
  for (const pipeline::NodePart& part : frame.nodes) {
    const NodeMap* m = nullptr;
    for (const NodeMap& n : nodes_)
      if (n.node_id == part.node_id) m = &n;
    if (!m) continue;
    for (const vc_features& fs : part.features) {
      if (fs.camera >= m->rig_camera.size() || m->rig_camera[fs.camera] < 0) continue;
      CameraObservations co;
      co.camera = m->rig_camera[fs.camera];
      const uint16_t count = std::min<uint16_t>(fs.feature_count, VC_PROTO_MAX_FEATURES);
      for (uint16_t i = 0; i < count; ++i) {
        const vc_feature& f = fs.features[i];
        if (f.feature_id >= co.features.size()) continue;
        Observation& o = co.features[f.feature_id];
        o.present = true;
        o.state = f.state;
        o.uv_px = cv::Point2d(f.u, f.v);
        o.confidence = f.confidence;
      }
      obs_.push_back(co);
    }
  }
  std::optional<cv::Vec3d> right;
  if (heading_)
    if (const auto h = heading_->latest(); h && h->seq <= frame.seq && frame.seq - h->seq <= kHeadingMaxAge)
      right = cv::Vec3d(h->right[0], h->right[1], h->right[2]);
  tri_->set_body_right(right);
  // The merged hull (README, "On the body"): off for a frame without one (an older session, no hull).
  const bool hull = frame.merged && grid_.valid(nullptr) && frame.voxel_count == grid_.count() &&
                    hull_.set(grid_, frame.rle.data(), frame.rle.size());
  if (!hull) hull_.clear();
  const std::array<pipeline::Feature3D, 5> r = tri_->process(obs_, hull ? &hull_ : nullptr);
  frame.features3d.assign(r.begin(), r.end());
  frame.triangulated = true;
}

}  // namespace vc::triangulate
