// The figures of the hardware-in-loop tests (`voxcap hil`), computed from timestamp streams alone: no
// device is touched here, so every rule is unit-tested on synthetic streams (tests/measure_test.cpp)
// and the same code judges a real rig and its emulated twin.
//
//   match_train    the pulses a trigger output sent against the edges an input saw: pairs each edge
//                  with its pulse by time (after the median offset between the two clocks' views),
//                  counts missed pulses and extra edges (glitches), the period jitter of the seen edges
//                  and the input's own counter gaps (wrap-aware for a 32-bit kernel counter).
//   align_frames   camera frames against the pulses that triggered them: each frame paired with the
//                  pulse at (frame time − expected latency), offset percentiles, unpaired frames and
//                  pulses without a frame, per camera.
//   judge_*        PASS / FAIL with the reason, the rule a test applies to its figures.
//
// Pairing is greedy in time order: for each sent pulse, the seen edge closest to where it is expected
// within ±tolerance·period is its edge; edges before that window, or a second edge in it, are extra.
// Limits: a constant offset between the clocks is removed (its median), a drifting one is not; an
// offset wider than tolerance·period drifting over a run would show as missed + extra.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace vc::hil {

// Percentiles of a sample (nearest rank on the sorted values), in the values' unit; NaN when empty.
struct Percentiles {
  size_t n = 0;
  double min = std::numeric_limits<double>::quiet_NaN();
  double p50 = std::numeric_limits<double>::quiet_NaN();
  double p95 = std::numeric_limits<double>::quiet_NaN();
  double p99 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};
Percentiles percentiles(std::vector<double> values);

// One pulse: its counter and the time of its leading edge, CLOCK_MONOTONIC ns.
struct Stamp {
  uint64_t seq = 0;
  int64_t t_ns = 0;
};

struct TrainOptions {
  double rate_hz = 60;     // the train's nominal rate, (0, 100000]
  double tolerance = 0.3;  // an edge pairs with a pulse within ± this fraction of a period, (0, 0.5)
  // Width of the input's counter (`Stamp::seq` of the seen edges): 64, or 32 for a raw kernel
  // line_seqno that wraps; gaps are counted modulo 2^seq_bits.
  int seq_bits = 64;

  bool valid(std::string* why) const;
  double period_ns() const { return 1e9 / rate_hz; }
};

struct TrainResult {
  uint64_t sent = 0, seen = 0;
  uint64_t matched = 0;   // seen edges paired with a sent pulse
  uint64_t missed = 0;    // sent pulses no edge was seen for
  uint64_t extra = 0;     // seen edges with no pulse (glitches, a second edge per pulse, noise)
  uint64_t seq_gaps = 0;  // pulses the input's own counter skipped (its event queue overflowed)
  double offset_us = std::numeric_limits<double>::quiet_NaN();  // median (seen − sent)
  double period_us = std::numeric_limits<double>::quiet_NaN();  // mean interval of the matched edges
  // |interval − k·period| between consecutive matched edges (k = the whole number of periods between
  // them, at least 1), in µs: the period jitter the input saw.
  Percentiles jitter_us;
  // |seen − sent − offset| of the matched edges, µs: how far each edge strays from its pulse.
  Percentiles spread_us;
  std::vector<uint64_t> missed_seqs;  // the first kMaxListed missed pulses' seq
  std::vector<int64_t> extra_at_us;   // the first kMaxListed extra edges, µs after the first pulse sent
  static constexpr size_t kMaxListed = 16;
};

// `sent` and `seen` in any order (each is sorted by time here).
TrainResult match_train(std::vector<Stamp> sent, std::vector<Stamp> seen, const TrainOptions& options);

// One camera frame: the camera's index in the test, its driver sequence and its timestamp.
struct FrameStamp {
  int camera = 0;
  uint64_t sequence = 0;
  int64_t t_ns = 0;
};

struct AlignOptions {
  double rate_hz = 60;     // (0, 100000]
  double latency_us = 0;   // the sensor's frame time minus its trigger edge, expected
  double tolerance = 0.4;  // a frame pairs with the pulse within ± this fraction of a period, (0, 0.5)
  int cameras = 1;         // FrameStamp::camera in [0, cameras)

  bool valid(std::string* why) const;
};

struct CameraAlignment {
  int camera = 0;
  uint64_t frames = 0;
  uint64_t paired = 0;
  uint64_t unpaired = 0;              // frames with no pulse within the tolerance
  uint64_t duplicate = 0;             // a second frame on a pulse already paired (counted in unpaired too)
  uint64_t pulses_without_frame = 0;  // pulses between this camera's first and last paired pulse
  Percentiles offset_us;              // frame − pulse of the paired frames (signed), µs
};

struct AlignResult {
  uint64_t pulses = 0;
  std::vector<CameraAlignment> cameras;
};

AlignResult align_frames(std::vector<Stamp> pulses, std::vector<FrameStamp> frames,
                         const AlignOptions& options);

// The figures of a full-rig smoke run (filled from the aggregator's report).
struct SmokeFigures {
  size_t nodes = 0;                        // in the rig file
  size_t nodes_connected = 0;              // connected and running at the end
  std::vector<std::string> nodes_missing;  // ids of the others
  uint64_t pulses = 0;
  uint64_t frames = 0, complete = 0, degraded = 0, dropped = 0;
  double seconds = 0, fps = 0;
  double merged_p50_ms = 0, merged_p99_ms = 0;  // trigger → merged
  bool running = false;                         // every node was READY once and the run started
  bool merging_stopped = false;                 // aggregator::Report::merging_stopped()
};

enum class Status { Pass, Fail, Skip };
const char* to_string(Status status);  // "PASS", "FAIL", "SKIPPED"

struct Verdict {
  Status status = Status::Skip;
  std::string reason;  // why it failed or was skipped; for a pass, the one-line gist
};

// Every one of `expected` pulses sent and seen once: none missed, none extra, no counter gap; and the
// jitter's max under max_jitter_us when that is > 0.
Verdict judge_train(const TrainResult& r, uint64_t expected, double max_jitter_us = 0);
// Every camera delivered frames, every frame paired (none unpaired), no pulse without a frame inside
// the run; |offset − latency| under max_offset_us when that is > 0.
Verdict judge_alignment(const AlignResult& r, const AlignOptions& options, double max_offset_us = 0);
// Every node connected and ran, frames merged, merging never stopped.
Verdict judge_smoke(const SmokeFigures& f);

}  // namespace vc::hil
