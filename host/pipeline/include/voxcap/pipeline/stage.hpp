// The host's one stage lifecycle (after rpicam-apps' PostProcessingStage and libcamera's pipeline
// handlers): configure → start → process(frame)… → stop.
//
//   configure(ctx)  on the caller's thread, once, before start: read what the stage needs from the
//                   narrow context (the rig configuration, a log); throw on bad input (nothing runs then)
//   start()         on the caller's thread, before the first frame
//   process(frame)  on the stage's own thread (StageRunner), one frame at a time, in the order the
//                   frames reached it. An exception is counted and logged by the runner and the frame
//                   goes no further down the chain; the stage and the rig go on.
//   stop()          on the caller's thread, after the last process()
//
// A stage sees nothing of the aggregator: no sessions, no sockets, no other stage.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "voxcap/base/log.hpp"
#include "voxcap/pipeline/body_heading.hpp"
#include "voxcap/pipeline/frame.hpp"

namespace vc::config {
struct RigConfig;
}

namespace vc::pipeline {

// What a stage may know of the host. Borrowed: lives as long as the pipeline that passes it.
struct StageContext {
  const config::RigConfig* rig = nullptr;  // the rig being run (nodes, grid, calibration, ...)
  log::Fn log;  // lines are prefixed with the stage's name by the runner; none: spdlog's default logger
  // The fit's last torso right, shared by every stage of one pipeline (the context is copied to each
  // stage: they share this one object). The fit publishes it, the triangulation reads it.
  std::shared_ptr<BodyHeading> body_heading = std::make_shared<BodyHeading>();
  // The names of the pipeline's chain stages in order (Pipeline::start fills it): Frame's
  // t_stage_start_ns / t_stage_end_ns are in this order.
  std::vector<std::string> chain;
};

class Stage {
 public:
  virtual ~Stage() = default;
  virtual std::string name() const = 0;  // short, for the log and the report: "merge", "record"
  virtual void configure(const StageContext& ctx) { (void)ctx; }
  virtual void start() {}
  virtual void process(Frame& frame) = 0;
  virtual void stop() {}
};

}  // namespace vc::pipeline
