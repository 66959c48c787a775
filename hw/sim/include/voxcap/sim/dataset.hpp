// Writes a rendered sequence with its ground truth to a folder (what `voxcap sim` does):
//   DIR/rig.yaml                                  the calibration (hw/rig/README.md), incl. the grid
//   DIR/background/cam<k>/<i>.png                 empty-room frames, i = 0..backgrounds-1
//   DIR/cam<k>/<frame>.png                        camera frames, frame = 0..frames-1
//   DIR/truth/silhouettes/cam<k>/<frame>.png      true silhouettes (0/255)
//   DIR/truth/shadows/cam<k>/<frame>.png          floor pixels in the performer's shadow (0/255)
//   DIR/truth/joints.csv                          frame,joint,x,y,z (metres, world)
//   DIR/truth/features.csv                        frame,camera,feature,u,v,visible
//   DIR/truth/motion.bvh                          the performer's skeleton motion (world, z up, m)
//   DIR/truth/scene.yaml                          how the sequence was made (motion, seed, ...)
// Frame and image numbers are plain decimals without padding. PNGs are written with cv::imwrite
// (RGB converted to OpenCV's BGR order there).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "voxcap/sim/scene.hpp"

namespace vc::sim {

struct DatasetOptions {
  int frames = 0;            // 0: the motion's natural length (lead-in + clip or one cycle)
  int backgrounds = 30;
  bool shadows = true;       // write truth/shadows
  bool motion_bvh = true;    // write truth/motion.bvh
  int png_compression = 1;   // 0..9 (cv::IMWRITE_PNG_COMPRESSION)
  int threads = 0;           // 0: one per hardware thread
  std::function<void(int done, int total)> progress;  // called from worker threads, serialised

  bool valid(std::string* why) const;
};

struct DatasetSummary {
  int frames = 0;
  int cameras = 0;
  int backgrounds = 0;
  std::size_t files = 0;
  double seconds = 0;
  double render_ms_per_image = 0;  // average CPU-side render time of one camera frame
  std::vector<std::string> notes;  // e.g. why motion.bvh was not written
};

// Throws std::invalid_argument for invalid options and std::runtime_error for I/O failures.
DatasetSummary write_dataset(const Scene& scene, const DatasetOptions& options, const std::string& dir);

}  // namespace vc::sim
