// `voxcap bench edge`: speed, instruction counts and memory of the edge's per-frame work (two
// cameras: subtraction, clean-up, partial-hull carving, RLE) on ray-cast 640x480 frames, next to two
// references run on the same frames: OpenCV's BackgroundSubtractorMOG2 (shadow detection on) and a
// plain per-voxel lookup-table carve. Every carve rule is measured: the centre rule (the top-level
// keys), the footprint rule (`carve_footprint`) and the subpixel rule (`carve_subpixel`), on the same
// masks. The JSON keys are documented
// in tests/bench/README.md.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace vc::bench {

struct EdgeBenchOptions {
  int grid = 128;      // voxels per axis of the cubic grid
  int frames = 20;     // measured frames (medians are reported)
  int bg_frames = 16;  // empty-room frames the background model learns from
  int width = 640;     // per camera
  int height = 480;
  bool callgrind = true;  // instruction counts via a child under valgrind --tool=callgrind
  bool rss = true;        // peak resident memory via a child that runs only the edge pipeline
  int grow_px = -1;       // the subtraction's limb-scale cue (bgmodel.h grow_px); < 0: its default
  double grow_flat = -1;  // the cue in the shadow band over a flat background (bgmodel.h); < 0: its default
  std::string self_exe;   // the voxcap-bench binary, re-run as the measuring child ("" = /proc/self/exe)

  bool valid(std::string* why) const;
};

// Runs the whole benchmark for one grid size and returns its JSON object.
nlohmann::json run_edge_bench(const EdgeBenchOptions& options);

// Child side: `mode` is "rss" or "rss-footprint" (run the edge pipeline alone with the centre or
// footprint carve rule, report peak memory) or "callgrind" (count instructions per stage with
// callgrind client requests). Frames come from `frames_file`,
// written by the parent. Returns the child's JSON (empty for callgrind, which writes dump files).
nlohmann::json run_edge_bench_child(const EdgeBenchOptions& options, const std::string& mode,
                                    const std::string& frames_file);

}  // namespace vc::bench
