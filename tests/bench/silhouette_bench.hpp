// `voxcap-bench silhouettes`: the edge's silhouettes (vc_subtract + the clean-up, as the edge runs
// them) against hw/sim's truth, offline. For a motion, an appearance and a room preset it renders the empty
// room and a series of frames for each chosen camera of a sim rig, learns the background model, runs
// the subtraction and clean-up with the defaults of voxcap/subtraction.h and counts, per camera and
// overall: body-pixel recall, recall per body part (each truth-silhouette pixel is labelled with the
// part its viewing ray hits first, by ray casting the scene's primitives), precision (share of mask
// pixels that are body), floor-shadow pixels kept as foreground, and the shares of pixels that went
// through the shadow test and were called shadow. With nodes > 0 it does the same for every camera of a
// rig of that many nodes (2 cameras each) and also carves each node's partial hull from its two masks
// with the edge's carver (vc_carver_run, the chosen rule), ANDs them as the host merges, and scores
// the merged hull against hw/sim's true occupancy: body recall overall and per part group, hull
// precision (share of hull voxels within one voxel of the body), as `voxcap rig --emulated` does live.
// JSON keys in tests/bench/README.md.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace vc::bench {

struct SilhouetteBenchOptions {
  std::string motion = "wave";         // a built-in motion (voxcap sim --list) or a .bvh path
  std::string appearance = "default";  // an appearance preset
  std::string room = "default";        // a room preset (vc::sim::room_presets(): floor and wall textures)
  int frames = 6;                      // frames evaluated per camera ...
  int every = 9;                       // ... this many frames apart, from the end of the lead-in
  int rig_cameras = 6;                 // cameras of the sim rig layout
  std::vector<int> cameras;            // which of them (empty = all)
  int width = 640, height = 480;
  int bg_frames = 30;              // empty-room frames learnt (VC_BACKGROUND_FRAMES)
  double shadow_texture_k = -1;    // < 0: the default of voxcap/subtraction.h; 0 = texture test off
  double shadow_flat_margin = -1;  // < 0: the default of voxcap/edge/bgmodel.h; 0 = flat-patch test off
  int grow_px = -1;                // < 0: the default of voxcap/edge/bgmodel.h; 0 = limb-scale cue off
  double grow_sigma = -1;          // < 0: the default of voxcap/edge/bgmodel.h
  double grow_flat = -1;           // < 0: the default of voxcap/edge/bgmodel.h; 0 = not in the band
  std::string png_dir;             // when set: the worst frame of each camera as a PNG here
  int nodes = 0;                   // > 0: a rig of this many nodes (rig_cameras = 2 * nodes, all cameras) ...
  int grid = 128;                  // ... carved into a grid^3 over the emulated rig's volume ...
  std::string carve = "subpixel";  // ... with this rule (centre, footprint, subpixel), merged and scored

  bool valid(std::string* why) const;
};

// Runs the evaluation; throws std::invalid_argument for an unknown motion or appearance.
nlohmann::json run_silhouette_bench(const SilhouetteBenchOptions& options);

// The JSON as a text table.
void print_silhouette_table(const nlohmann::json& result);

}  // namespace vc::bench
