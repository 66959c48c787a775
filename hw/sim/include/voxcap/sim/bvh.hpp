// BVH motion files: parse any BVH hierarchy (channel order honoured per joint, as written), give
// the skeleton and per-frame poses in the file's own units and axes, and write poses back out.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "voxcap/sim/skeleton.hpp"

namespace vc::sim {

enum class BvhChannel { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

struct BvhClip {
  // Offsets in file units. An "End Site" becomes a joint named "<parent>_end" with end_site = true.
  Skeleton skeleton;
  std::vector<std::vector<BvhChannel>> channels;  // per joint, in file order (empty for End Sites)
  std::vector<int> first_channel;                 // per joint: index of its first value in a frame
  int channel_count = 0;                          // values per frame
  int frames = 0;
  double frame_time_s = 0;                        // as written in the file
  int frame_time_decimals = -1;                   // digits after the point as written, -1 if none
  std::vector<double> values;                     // frames * channel_count, row-major

  const double* frame_values(int frame) const {
    return values.data() + static_cast<std::size_t>(frame) * static_cast<std::size_t>(channel_count);
  }
  // Local rotations R = R_c1 * R_c2 * R_c3 (channels in the order written, degrees); the root's
  // position channels go to root_position and other joints' to translation, all multiplied by
  // `scale` (file units -> metres). Axes stay the file's.
  Pose pose(int frame, double scale = 1.0) const;
  // The skeleton with offsets multiplied by scale.
  Skeleton scaled_skeleton(double scale) const;
};

// Parses BVH text. Throws std::runtime_error("<source_name>:<line>: <what>") on malformed input;
// never reads out of bounds, whatever the bytes.
BvhClip parse_bvh(std::string_view text, const std::string& source_name = "bvh");
// Reads and parses a file; errors name the path.
BvhClip read_bvh(const std::string& path);

// Writes poses of `skeleton` as BVH: joints with end_site = true become End Sites, the root gets
// "Xposition Yposition Zposition Zrotation Yrotation Xrotation", every other joint
// "Zrotation Yrotation Xrotation"; positions and offsets in the skeleton's units (%.6f), angles
// in degrees (%.6f). Pose translations on non-root joints are not representable and must be empty.
std::string format_bvh(const Skeleton& skeleton, const std::vector<Pose>& poses, double frame_time_s);
void write_bvh(const std::string& path, const Skeleton& skeleton, const std::vector<Pose>& poses,
               double frame_time_s);

}  // namespace vc::sim
