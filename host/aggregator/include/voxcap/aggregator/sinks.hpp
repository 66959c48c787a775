// Sinks for the aggregator's merged frames: several at once (FanoutSink), and the session recording
// (RecordingSink: every merged frame, the front nodes' features and the nodes' STATS go to a
// vc::record::Recorder; synced to disk about once a second).
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <vector>

#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::aggregator {

class FanoutSink : public Sink {
 public:
  explicit FanoutSink(std::vector<Sink*> sinks) : sinks_(std::move(sinks)) {}
  void frame(const assemble::MergedFrame& f) override {
    for (Sink* s : sinks_) s->frame(f);
  }
  void features(uint16_t node, uint64_t seq, const vc_features& f) override {
    for (Sink* s : sinks_) s->features(node, seq, f);
  }
  void stats(uint16_t node, const vc_stats& st) override {
    for (Sink* s : sinks_) s->stats(node, st);
  }

 private:
  std::vector<Sink*> sinks_;
};

class RecordingSink : public Sink {
 public:
  // Creates the session folder `parent/<rig name>-<UTC time>` (throws std::runtime_error).
  RecordingSink(const config::RigConfig& rig, const std::filesystem::path& parent);
  ~RecordingSink() override;  // closes the session cleanly
  void frame(const assemble::MergedFrame& f) override;
  void features(uint16_t node, uint64_t seq, const vc_features& f) override;
  void stats(uint16_t node, const vc_stats& st) override;
  const std::filesystem::path& dir() const { return dir_; }
  uint64_t records() const { return rec_.records(); }

 private:
  void maybe_sync();
  std::filesystem::path dir_;
  record::Recorder rec_;
  record::FrameRecord frame_;  // reused: no allocation per frame once warmed up
  std::chrono::steady_clock::time_point last_sync_;
};

}  // namespace vc::aggregator
