// The triangulation stage of the host's pipeline ("triangulate", a chain stage after merge): each
// frame's FEATURES (per node, per node camera) mapped to the rig's cameras, triangulated by a
// FeatureTriangulator into Frame::features3d (five entries, vc_feature_id order, performer's sides).
// Options from [triangulation] of the rig config; configure() throws on a rig it cannot use.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "voxcap/pipeline/stage.hpp"
#include "voxcap/triangulate/triangulate.hpp"

namespace vc::triangulate {

class TriangulateStage : public pipeline::Stage {
 public:
  // The fit's torso right is used while it is at most this many frames older than the frame named.
  static constexpr uint64_t kHeadingMaxAge = 30;

  std::string name() const override { return "triangulate"; }
  void configure(const pipeline::StageContext& ctx) override;
  void process(pipeline::Frame& frame) override;

  // The running solver (after configure), e.g. for its per-camera swaps; nullptr before.
  const FeatureTriangulator* triangulator() const { return tri_.get(); }
  // The hull rule on (default) or off, its rejection of hypotheses off (default) or on (after
  // configure; FeatureTriangulator::set_hull_rule, set_hull_reject).
  void set_hull_rule(bool on) {
    if (tri_) tri_->set_hull_rule(on);
  }
  void set_hull_reject(bool on) {
    if (tri_) tri_->set_hull_reject(on);
  }

 private:
  struct NodeMap {
    uint16_t node_id;
    std::vector<int> rig_camera;  // node camera index -> rig camera index
  };
  std::vector<NodeMap> nodes_;
  std::unique_ptr<FeatureTriangulator> tri_;
  rig::VoxelGrid grid_;                             // the rig's grid: the merged hull's
  HullMap hull_;                                    // this frame's merged hull, decoded (kept)
  std::vector<CameraObservations> obs_;             // kept: no allocation per frame after the first
  std::shared_ptr<pipeline::BodyHeading> heading_;  // the fit's torso right (the pipeline's), or null
};

// The rig camera index of node `node_id`'s camera `camera` in `rig`, or -1.
int rig_camera_of(const config::RigConfig& rig, uint16_t node_id, uint16_t camera);
// The rig camera indices of the front nodes' cameras, ascending.
std::vector<int> front_cameras(const config::RigConfig& rig);

}  // namespace vc::triangulate
