// Captures on disk and the report: image folders in, the text report and the PNG out.
//
// Folder layout (what `voxcap calibrate capture` writes and `voxcap calibrate solve --images` reads):
//   DIR/<camera>/<frame>.png   one folder per camera (sorted by name, digits compared as numbers), frames
//                              matched across cameras by file name (.png .jpg .jpeg .bmp .tif .tiff);
//                              the frame named `floor` (or --floor NAME) is the board lying on the floor.
#pragma once

#include <functional>
#include <string>

#include "voxcap/calibrate/solve.hpp"

namespace vc::calibrate {

inline constexpr int kMaxCameras = 64;
inline constexpr int kMaxFrames = 100000;
inline constexpr long long kMaxImageBytes = 256LL << 20;

// Reads every image and detects the board. Throws std::runtime_error naming the file or folder for what
// cannot be read: not a folder, no camera folders, an image that does not decode or is over the size
// limits, images of one camera in different sizes. `progress(done, total)` is called after each image.
Capture load_capture(const std::string& dir, const BoardSpec& board, const std::string& floor_name = "floor",
                     const std::function<void(int, int)>& progress = {});

// The report as text: per camera views, edge-on views dropped, reprojection RMS and max, coverage grid,
// the voxel grid check, warnings.
std::string report_text(const Capture& capture, const Solution& solution);

// A PNG (BGR image): the cameras and the voxel grid seen from above (x-y) and from the side (x-z), each
// camera drawn as its centre and viewing direction and labelled with its name and reprojection RMS.
cv::Mat report_image(const Solution& solution);

// Writes DIR/report.txt and DIR/report.png (creating DIR). Throws std::runtime_error on I/O failure.
void write_report(const std::string& dir, const Capture& capture, const Solution& solution);

}  // namespace vc::calibrate
