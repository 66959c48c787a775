// The host's frame pipeline: stages (stage.hpp), each on its own thread behind a bounded queue
// (queue.hpp), connected as a chain followed by consumers:
//
//   push ─► [chain stage 1] ─► [chain stage 2] ─► … ─┬─► [consumer a]
//                                                    └─► [consumer b] …
//
// Chain stages (then()) work on a frame alone and may change it: merge today; triangulation and
// fitting later. Consumers (tap()) each get every frame that leaves the chain, shared and read-only:
// recording, the emulated rig's scorer; a viewer and stream-out later. Every stage states its queue's
// overflow policy: a stage that must see every frame (recording) uses Overflow::Block, which holds
// back the stage before it (a pipeline thread); a live consumer uses Overflow::DropOldest (counted).
//
// Adding a stage is one line before start():
//   pipeline.tap(std::make_unique<viewer::ViewStage>(...), {.capacity = 2, .overflow =
//   Overflow::DropOldest});
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "voxcap/pipeline/queue.hpp"
#include "voxcap/pipeline/stage.hpp"

namespace vc::pipeline {

struct QueueOptions {
  size_t capacity = 64;
  Overflow overflow = Overflow::Block;
};

struct StageReport {
  std::string name;
  Overflow overflow = Overflow::Block;
  QueueCounters queue;     // accepted, dropped (by the policy), depth now and at most
  uint64_t processed = 0;  // process() calls that returned
  uint64_t errors = 0;     // process() calls that threw
  std::string last_error;
  double busy_ms_mean = 0, busy_ms_max = 0;  // time in process()
};

struct PipelineReport {
  std::vector<StageReport> stages;  // in pipeline order: the chain, then the consumers
  const StageReport* stage(const std::string& name) const {
    for (const StageReport& s : stages)
      if (s.name == name) return &s;
    return nullptr;
  }
};

// One stage on its own thread behind its queue. The Pipeline owns these; tests use them alone.
class StageRunner {
 public:
  StageRunner(std::unique_ptr<Stage> stage, QueueOptions queue);
  ~StageRunner();  // stop()
  StageRunner(const StageRunner&) = delete;
  StageRunner& operator=(const StageRunner&) = delete;

  void configure(const StageContext& ctx);
  void start();
  // Hands a frame to the stage by its queue's policy (Block: may wait). False when it was not queued
  // (dropped by the policy, or the runner is stopping).
  bool push(FramePtr frame);
  // Closes the queue (waiting producers give up), lets the stage finish what was queued, joins its
  // thread and calls Stage::stop(). Idempotent.
  void stop();
  // Where processed frames go next (the next chain stage, or the consumers).
  void set_next(std::vector<StageRunner*> next) { next_ = std::move(next); }
  // Its place in the chain: it stamps Frame::t_stage_start_ns / t_stage_end_ns[index] (a consumer,
  // the default, stamps nothing).
  void set_chain_index(int index) { chain_index_ = index; }

  StageReport report() const;
  Stage& stage() { return *stage_; }

 private:
  void run();
  void log(log::Level level, const std::string& line) const;

  std::unique_ptr<Stage> stage_;
  std::string name_;
  BoundedQueue<FramePtr> queue_;
  std::vector<StageRunner*> next_;
  int chain_index_ = -1;
  StageContext ctx_;
  std::thread thread_;
  bool started_ = false, stopped_ = false;
  mutable std::mutex mu_;  // guards the figures below
  uint64_t processed_ = 0, errors_ = 0;
  std::string last_error_;
  double busy_ns_sum_ = 0, busy_ns_max_ = 0;
};

class Pipeline {
 public:
  explicit Pipeline(StageContext ctx);
  ~Pipeline();  // stop()
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Appends a stage to the chain (before any consumer is added). Before start() only.
  template <class S>
  S& then(std::unique_ptr<S> stage, QueueOptions queue) {
    S& s = *stage;
    add(std::move(stage), queue, false);
    return s;
  }
  // Adds a consumer at the end. Before start() only.
  template <class S>
  S& tap(std::unique_ptr<S> stage, QueueOptions queue) {
    S& s = *stage;
    add(std::move(stage), queue, true);
    return s;
  }

  // Configures every stage (in order; the first exception propagates and nothing runs), then starts
  // them from the last to the first.
  void start();
  // A frame into the first chain stage (or, without one, to every consumer). Called by the assembly
  // stage's thread; may wait when the first stage's queue blocks.
  bool push(FramePtr frame);
  // From the first stage to the last, each drains what it holds before the next is closed: a frame
  // pushed before stop() reaches every Block stage. Idempotent.
  void stop();

  PipelineReport report() const;
  size_t size() const { return chain_.size() + taps_.size(); }

 private:
  void add(std::unique_ptr<Stage> stage, QueueOptions queue, bool tap);
  StageContext ctx_;
  std::vector<std::unique_ptr<StageRunner>> chain_, taps_;
  bool started_ = false, stopped_ = false;
};

}  // namespace vc::pipeline
