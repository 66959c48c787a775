#include "voxcap/pipeline/pipeline.hpp"

#include <fmt/core.h>

#include <chrono>
#include <exception>
#include <stdexcept>

#include "voxcap/base/clock.hpp"

namespace vc::pipeline {

const char* overflow_name(Overflow o) {
  switch (o) {
    case Overflow::Block:
      return "block";
    case Overflow::DropOldest:
      return "drop-oldest";
    case Overflow::DropNewest:
      return "drop-newest";
  }
  return "?";
}

StageRunner::StageRunner(std::unique_ptr<Stage> stage, QueueOptions queue)
    : stage_(std::move(stage)), queue_(queue.capacity, queue.overflow) {
  if (!stage_) throw std::invalid_argument("pipeline: a null stage");
  name_ = stage_->name();
}

StageRunner::~StageRunner() {
  try {
    stop();
  } catch (...) {  // Stage::stop() threw: a destructor must not
  }
}

void StageRunner::log(log::Level level, const std::string& line) const {
  ctx_.log(level, name_ + ": " + line);
}

void StageRunner::configure(const StageContext& ctx) {
  ctx_ = ctx;
  ctx_.log = log::or_spdlog(ctx.log);
  StageContext own = ctx;
  own.log = [this](log::Level level, const std::string& line) { log(level, line); };
  stage_->configure(own);
}

void StageRunner::start() {
  if (started_) return;
  stage_->start();
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

bool StageRunner::push(FramePtr frame) {
  return queue_.push(std::move(frame));
}

void StageRunner::run() {
  using Clock = std::chrono::steady_clock;
  auto last_error_log = Clock::time_point{};
  uint64_t errors_unlogged = 0;
  const bool stamp = chain_index_ >= 0 && static_cast<size_t>(chain_index_) < Frame::kTimedStages;
  const auto slot = static_cast<size_t>(chain_index_);
  while (std::optional<FramePtr> f = queue_.pop()) {
    auto t0 = Clock::now();
    if (stamp) (*f)->t_stage_start_ns[slot] = vc::monotonic_ns();
    bool ok = true;
    std::string error;
    try {
      stage_->process(**f);
    } catch (const std::exception& e) {
      ok = false;
      error = e.what();
    } catch (...) {
      ok = false;
      error = "unknown exception";
    }
    double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
    if (stamp) (*f)->t_stage_end_ns[slot] = vc::monotonic_ns();
    {
      std::lock_guard<std::mutex> g(mu_);
      busy_ns_sum_ += ns;
      if (ns > busy_ns_max_) busy_ns_max_ = ns;
      if (ok) {
        processed_++;
      } else {
        errors_++;
        last_error_ = error;
      }
    }
    if (!ok) {
      // A failing stage must not flood the log at 60 Hz: the first error, then at most one line a
      // second with the count in between.
      errors_unlogged++;
      auto now = Clock::now();
      if (now - last_error_log >= std::chrono::seconds(1)) {
        log(log::Level::err, fmt::format("frame {}: {} ({} frame(s) failed since the last such line)",
                                         (*f)->seq, error, errors_unlogged));
        errors_unlogged = 0;
        last_error_log = now;
      }
      continue;  // a frame a stage failed on goes no further
    }
    for (StageRunner* n : next_) n->push(*f);
  }
}

void StageRunner::stop() {
  if (stopped_) return;
  stopped_ = true;
  queue_.close();
  if (thread_.joinable()) thread_.join();
  if (started_) stage_->stop();
}

StageReport StageRunner::report() const {
  StageReport r;
  r.name = name_;
  r.overflow = queue_.overflow();
  r.queue = queue_.counters();
  std::lock_guard<std::mutex> g(mu_);
  r.processed = processed_;
  r.errors = errors_;
  r.last_error = last_error_;
  uint64_t calls = processed_ + errors_;
  r.busy_ms_mean = calls ? busy_ns_sum_ / double(calls) / 1e6 : 0;
  r.busy_ms_max = busy_ns_max_ / 1e6;
  return r;
}

Pipeline::Pipeline(StageContext ctx) : ctx_(std::move(ctx)) {}

Pipeline::~Pipeline() {
  try {
    stop();
  } catch (...) {
  }
}

void Pipeline::add(std::unique_ptr<Stage> stage, QueueOptions queue, bool tap) {
  if (started_) throw std::logic_error("pipeline: stages are added before start()");
  if (!tap && !taps_.empty()) throw std::logic_error("pipeline: chain stages come before the consumers");
  auto r = std::make_unique<StageRunner>(std::move(stage), queue);
  (tap ? taps_ : chain_).push_back(std::move(r));
}

void Pipeline::start() {
  if (started_) return;
  ctx_.chain.clear();
  for (size_t i = 0; i < chain_.size(); i++) {
    ctx_.chain.push_back(chain_[i]->stage().name());
    chain_[i]->set_chain_index(static_cast<int>(i));
  }
  for (auto& r : chain_) r->configure(ctx_);
  for (auto& r : taps_) r->configure(ctx_);
  std::vector<StageRunner*> consumers;
  for (auto& r : taps_) consumers.push_back(r.get());
  for (size_t i = 0; i < chain_.size(); i++)
    chain_[i]->set_next(i + 1 < chain_.size() ? std::vector<StageRunner*>{chain_[i + 1].get()} : consumers);
  // Consumers first, so that nothing is pushed into a stage that is not running.
  for (auto& r : taps_) r->start();
  for (size_t i = chain_.size(); i-- > 0;) chain_[i]->start();
  started_ = true;
}

bool Pipeline::push(FramePtr frame) {
  if (!chain_.empty()) return chain_.front()->push(std::move(frame));
  bool all = true;
  for (auto& r : taps_) all = r->push(frame) && all;
  return all;
}

void Pipeline::stop() {
  if (stopped_) return;
  stopped_ = true;
  for (auto& r : chain_) r->stop();
  for (auto& r : taps_) r->stop();
}

PipelineReport Pipeline::report() const {
  PipelineReport p;
  for (const auto& r : chain_) p.stages.push_back(r->report());
  for (const auto& r : taps_) p.stages.push_back(r->report());
  return p;
}

}  // namespace vc::pipeline
