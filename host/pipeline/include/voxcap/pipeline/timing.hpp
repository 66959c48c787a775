// Where a frame's trigger → pose time goes, from the stamps the host puts on it: each node's HULL
// received (NodePart::t_received_ns), the frame leaving the assembler (t_assembled_ns), each chain
// stage's start and end of process() (t_stage_start_ns / t_stage_end_ns, stamped by the StageRunner).
// Cheap: a few subtractions per frame, rows kept up to a bound. `voxcap demo` prints the split and
// writes the rows (--timing-csv); host/fit/README.md "where the latency goes" reads them.
//
// The segments of one frame, in ms, add up to its last chain stage's end less its trigger:
//   edges        trigger → the first node's HULL received (render or exposure, the edge's work, the link)
//   last_node    first → last HULL received (how long the slowest node kept the others waiting)
//   assembly     last HULL received → the frame left the assembler (the assembly thread's queue, and for
//                a frame some node never sent its hull for, the wait for the deadline or its next message)
//   <stage>_queue  the previous stage's end → this stage's start (its queue, its thread's wake-up)
//   <stage>        this stage's process()
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "voxcap/pipeline/frame.hpp"

namespace vc::pipeline {

struct FrameTiming {
  uint64_t seq = 0;
  bool degraded = false;
  std::vector<uint16_t> missing;                     // nodes without a HULL in this frame
  std::vector<std::pair<uint16_t, double>> hull_ms;  // each node's HULL received, ms after the trigger
  double assembled_ms = 0;
  std::vector<std::pair<double, double>> stage_ms;  // each chain stage's start and end, ms after the trigger
  // The segments above, in order: edges, last_node, assembly, then <stage>_queue and <stage> per stage.
  std::vector<double> segments_ms;
  double total_ms = 0;  // the last chain stage's end after the trigger (the sum of the segments)
};

// The timing of a frame that went through `chain_stages` chain stages; false (nothing filled) when it
// lacks a stamp (no trigger time, no hull, a stage it never reached) or a stamp goes backwards.
bool frame_timing(const Frame& f, size_t chain_stages, FrameTiming* out);

// The segments' names for a chain (StageContext::chain): edges, last_node, assembly, then
// <stage>_queue, <stage> per chain stage.
std::vector<std::string> timing_segments(const std::vector<std::string>& chain);

struct LatencySplit {
  std::vector<std::string> segments;
  uint64_t frames = 0;          // frames timed
  std::vector<double> mean_ms;  // per segment, over every timed frame
  double tail_from_ms = 0;      // the tail is the slowest 1% (at least one frame): from this total_ms
  uint64_t tail_frames = 0, tail_degraded = 0;
  std::vector<double> tail_mean_ms;  // per segment, over the tail
};

// Collects frames' timings (the first max_rows of a run; the split is over those) and splits them.
class TimingLog {
 public:
  explicit TimingLog(size_t max_rows = 16384) : max_rows_(max_rows) {}
  void set_chain(std::vector<std::string> chain) { chain_ = std::move(chain); }
  const std::vector<std::string>& chain() const { return chain_; }
  // Adds the frame when it has every stamp (frame_timing); false otherwise or beyond max_rows.
  bool add(const Frame& f);
  const std::vector<FrameTiming>& rows() const { return rows_; }
  LatencySplit split() const;

 private:
  size_t max_rows_;
  std::vector<std::string> chain_;
  std::vector<FrameTiming> rows_;
};

}  // namespace vc::pipeline
