// Offline carving of image folders with the edge's own code (voxcap carve): silhouettes by the edge's
// background subtraction (edge/core bgmodel + cleanup), or read from masks, or by a threshold with
// dilate/erode; the hull by the edge's carver (edge/core carver, the host's default subpixel rule) over
// DESIGN.md's voxel grid, one carver per pair of cameras as on the edge nodes, the pairs' partial hulls
// ANDed as on the host.
//
// Images are matched to the calibration's cameras by name: for a camera named NAME, either the folder
// DIR/NAME/ holds its frames (image files, in name order: frame f is the f-th file of every camera), or
// DIR/NAME.EXT is its one frame (EXT one of png jpg jpeg bmp ppm pgm pnm tif tiff, tried in that order).
// Cameras with neither are left out (CarveSession::skipped()); at least two must be found, all with the
// same number of frames, each image the size its camera is calibrated for. --background and --silhouettes
// folders follow the same rule.
//
// --auto N: the grid whose longest side has N voxels around the region every matched camera sees. That
// region is found by sampling: a cube centred on the point nearest to all cameras' optical axes (least
// squares), of half-side the largest distance from that point to a camera centre, is sampled on a 96^3
// lattice; the points in front of every camera and inside its image are kept; the box of those points,
// grown by one lattice step, is sampled again at 96^3, and the box of the points kept there, grown by one
// step of that lattice, is the region.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/camera_model.h"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::calib {

// Bad input to a carve (a folder, an image, an option): one line.
struct CarveError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class MaskSource { Background, Silhouettes, Threshold };

inline constexpr int kMaxFramesPerCamera = 100000;
inline constexpr std::uintmax_t kMaxImageBytes = std::uintmax_t{256} << 20;
inline constexpr int kMaxMorphologyPx = 100;
inline constexpr int kMaxAutoVoxels = 1024;  // --auto N: N in [2, 1024]

struct CarveOptions {
  std::string images;  // DIR
  MaskSource source = MaskSource::Threshold;
  std::string background;              // MaskSource::Background: DIR of empty-scene frames (same layout)
  std::string silhouettes;             // MaskSource::Silhouettes: DIR of masks (nonzero = foreground)
  double threshold = 0.5;              // MaskSource::Threshold: foreground where luminance / 255 > threshold
  int dilate_px = 0;                   // then dilated by a disc of this radius ...
  int erode_px = 0;                    // ... and eroded by one of this radius (Middlebury's recipe: 10, 7)
  std::optional<rig::VoxelGrid> grid;  // explicit grid; else auto_n; else the calibration's grid
  int auto_n = 0;
  vc_carve_rule rule = VC_CARVE_SUBPIXEL;

  bool valid(std::string* why) const;
};

// The grid of `n` voxels on the longest side around the region all `cameras` see (see above).
// Throws CarveError when they see no common region.
rig::VoxelGrid auto_grid(const rig::Calibration& calibration, const std::vector<int>& cameras, int n);

// A silhouette by threshold: luminance (OpenCV's BGR -> grey weights) / 255 > threshold, then dilated
// and eroded by discs of the given radii. Returns a 0/255 mask.
cv::Mat threshold_mask(const cv::Mat& bgr, double threshold, int dilate_px, int erode_px);

struct Hull {
  rig::VoxelGrid grid;
  std::vector<std::uint8_t> bits;  // DESIGN.md's order, LSB-first
  std::size_t occupied = 0;
  // Index bounding box of the occupied voxels; false when empty.
  bool bounds(int lo[3], int hi[3]) const;
};

class CarveSession {
 public:
  // Matches the folders, learns background models (MaskSource::Background), builds the carvers.
  // Throws CarveError for bad input.
  CarveSession(const rig::Calibration& calibration, const CarveOptions& options);
  ~CarveSession();
  CarveSession(const CarveSession&) = delete;
  CarveSession& operator=(const CarveSession&) = delete;

  int frames() const { return frames_; }
  const rig::VoxelGrid& grid() const { return grid_; }
  const std::vector<int>& cameras() const { return cameras_; }          // calibration indices, matched
  const std::vector<std::string>& skipped() const { return skipped_; }  // camera names without images
  // Name of frame f (the first matched camera's file stem), for output names.
  std::string frame_name(int f) const;
  // Carves frame f; the masks used are returned in *masks when given (one per matched camera).
  Hull carve(int f, std::vector<cv::Mat>* masks = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  rig::Calibration calibration_;
  CarveOptions options_;
  rig::VoxelGrid grid_;
  std::vector<int> cameras_;
  std::vector<std::string> skipped_;
  int frames_ = 0;
};

// Output files. Throw std::runtime_error when the file cannot be written.
// .npy (format 1.0): dtype |b1, shape (nx*ny*nz,), the flat occupancy in DESIGN.md's voxel order
// (numpy: np.load(p).reshape(nz, ny, nx)[k, j, i]).
void write_npy(const std::string& path, const Hull& hull);
// Binary little-endian PLY: one float32 x y z vertex per occupied voxel centre (world metres).
void write_ply(const std::string& path, const Hull& hull);
// PNG: the hull's projections along z (top: x right, y up), y (front: x right, z up) and x (side: y
// right, z up), side by side, each scaled to at least 256 pixels on its longest side.
void write_preview(const std::string& path, const Hull& hull);

}  // namespace vc::calib
