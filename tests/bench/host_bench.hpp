// `voxcap bench host`: the host's figures.
//   merge:  cost per frame of intersecting N partial hulls in the RLE domain (the assembler's merge),
//           for 3, 4 and 8 nodes at 64^3, 128^3 and 256^3, on human-shaped partial hulls: the simulator's
//           true body occupancy extruded along each node's horizontal viewing direction (what two nearby
//           views leave of a body: a prism around it), so run counts are those of real hulls.
//   triangulate: cost per frame of the host's triangulation stage (host/triangulate: five features,
//           RANSAC over views, left/right agreement) on synthetic edge observations of hw/sim's wave
//           motion (1 px noise, 5 % confident outliers, image-side labels), 6 and 8 cameras.
//   fit:    cost per frame of the host's skeleton fitting (host/fit) per stage — decoding the hull,
//           torso segmentation, PCA, layer 1, each layer-2 limb — at the method's settings (256 cylinder
//           samples, 15 angular steps) on hw/sim's true occupancy of a whole motion (default walk) at
//           128^3 over the default volume with 1 cm-noisy true features, beside the method's Table 1
//           (PCA 4 ms, torso segmentation 5.5 ms, layer 1 16 ms, one layer-2 segment 211 ms, 1 GHz CPU).
//   rig:    the emulated rig's sustained fps, trigger -> merged-hull latency (p50, p99), frames complete,
//           and the host's resident memory at the start and at the end of the run (default 10 minutes);
//           then one edge killed and restarted: its time to rejoin the run (rejoin_ms).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace vc::bench {

struct HostBenchOptions {
  std::vector<int> grids{64, 128, 256};
  std::vector<int> nodes{3, 4, 8};
  int repeats = 50;  // merges timed per configuration
  std::vector<int> tri_cameras{6, 8};
  int tri_frames = 240;  // triangulated frames timed per camera count
  int fit_frames = 0;    // fitted frames timed (0: the whole motion: lead-in and one cycle)
  std::string fit_motion = "walk";
  int fit_grid = 128;       // voxels along the default volume's x and y
  bool rig = true;          // run the emulated rig part
  double rig_minutes = 10;  // how long the emulated rig runs
  int rig_nodes = 3;
  int width = 640, height = 480;
  int rig_grid = 128;
};

// Runs the benchmark and returns the figures (keys documented in tests/bench/README.md).
nlohmann::json run_host_bench(const HostBenchOptions& o);

}  // namespace vc::bench
