#include "voxcap/aggregator/record_stage.hpp"

#include <fmt/chrono.h>
#include <fmt/core.h>

#include <ctime>
#include <stdexcept>

#include "voxcap/base/clock.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/record/from_proto.hpp"
#include "voxcap/record/pose.hpp"

namespace vc::aggregator {

static std::filesystem::path session_dir(const config::RigConfig& rig, const std::filesystem::path& parent) {
  std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::filesystem::path p =
      parent / fmt::format("{}-{:%Y%m%dT%H%M%SZ}", rig.name.empty() ? "rig" : rig.name, utc);
  for (int k = 2; std::filesystem::exists(p); k++)
    p = parent / fmt::format("{}-{:%Y%m%dT%H%M%SZ}-{}", rig.name.empty() ? "rig" : rig.name, utc, k);
  return p;
}

RecordStage::~RecordStage() {
  try {
    stop();
  } catch (...) {  // a destructor must not throw; the session stays readable up to its last record
  }
}

void RecordStage::configure(const pipeline::StageContext& ctx) {
  if (!ctx.rig) throw std::invalid_argument("record: the stage needs the rig configuration");
  const config::RigConfig& rig = *ctx.rig;
  dir_ = session_dir(rig, parent_);
  rec_.emplace(
      record::Recorder::create(dir_, rig.source, rig.calibration_path,
                               fmt::format(R"({{"rig":"{}","nodes":{}}})", rig.name, rig.nodes.size())));
  last_sync_ = std::chrono::steady_clock::now();
}

void RecordStage::process(pipeline::Frame& f) {
  frame_.seq = f.seq;
  frame_.t_trigger_ns = f.t_trigger_ns;
  frame_.t_merged_ns = f.t_merged_ns;
  frame_.grid_id = f.grid_id;
  frame_.voxel_count = f.voxel_count;
  frame_.occupied = f.occupied;
  frame_.degraded = f.degraded;
  frame_.nodes_present.assign(f.present.begin(), f.present.end());
  frame_.nodes_missing.assign(f.missing.begin(), f.missing.end());
  frame_.rle.assign(f.rle.begin(), f.rle.end());
  rec_->append(frame_);
  const uint64_t now = vc::monotonic_ns();
  for (const pipeline::NodePart& p : f.nodes) {
    for (const vc_features& feat : p.features) {
      record::to_record(p.node_id, f.seq, feat, &features_);
      rec_->append(features_);
    }
    for (const vc_stats& st : p.stats) rec_->append(record::to_record(p.node_id, now, st));
  }
  if (f.triangulated) {
    features3d_.seq = f.seq;
    features3d_.features.resize(f.features3d.size());
    for (size_t i = 0; i < f.features3d.size(); ++i)
      record::to_record(f.features3d[i], &features3d_.features[i]);
    rec_->append(features3d_);
  }
  // The fitting stage ran on this frame (it stamps t_fitted_ns; an initialization frame's pose has state
  // none): its pose, with the joint names in the session's first pose record.
  if (f.pose.t_fitted_ns != 0 || f.pose.valid()) {
    record::to_record(f.seq, f.pose, !pose_names_written_, &pose_);
    rec_->append(pose_);
    pose_names_written_ = true;
  }
  auto t = std::chrono::steady_clock::now();
  if (t - last_sync_ >= std::chrono::seconds(1)) {
    rec_->flush();
    last_sync_ = t;
  }
}

void RecordStage::stop() {
  if (rec_) rec_->close();
}

}  // namespace vc::aggregator
