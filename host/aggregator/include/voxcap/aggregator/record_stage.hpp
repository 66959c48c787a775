// The record stage: every frame that leaves the chain goes to the session recording (a
// vc::record::Recorder): its merged hull, the FEATURES of its front nodes (one record per camera), the
// STATS that rode on it, the triangulated 3D features and the fitted pose (host/record/include/voxcap/
// record/pose.hpp) when those stages ran on it; synced to disk about once a second, closed cleanly at stop.
// It must see every frame: add it with RecordStage::kQueue (Overflow::Block, ~8 s of frames at 60 Hz).
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>

#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::aggregator {

class RecordStage : public pipeline::Stage {
 public:
  static constexpr pipeline::QueueOptions kQueue{512, pipeline::Overflow::Block};

  // The session folder `parent/<rig name>-<UTC time>` is created at configure() (throws
  // std::runtime_error naming the path).
  explicit RecordStage(std::filesystem::path parent) : parent_(std::move(parent)) {}
  ~RecordStage() override;  // closes the session if stop() did not

  std::string name() const override { return "record"; }
  void configure(const pipeline::StageContext& ctx) override;
  void process(pipeline::Frame& frame) override;
  void stop() override;

  const std::filesystem::path& dir() const { return dir_; }  // after configure()
  uint64_t records() const { return rec_ ? rec_->records() : 0; }

 private:
  std::filesystem::path parent_, dir_;
  std::optional<record::Recorder> rec_;
  record::FrameRecord frame_;  // reused: no allocation per frame once warmed up
  record::FeatureRecord features_;
  record::Features3DRecord features3d_;  // the triangulation stage's 3D features, when it ran
  record::PoseRecord pose_;              // the fitting stage's pose, when it ran
  bool pose_names_written_ = false;      // the joint names go in the first pose record only
  std::chrono::steady_clock::time_point last_sync_;
};

}  // namespace vc::aggregator
