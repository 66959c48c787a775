// BVH motion files: read any BVH hierarchy (channel order honoured per joint, as written), giving
// the skeleton and per-frame poses in the file's own units and axes; write poses back out, as
// they are or as the standard humanoid that Blender and retargeting tools import as is.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "voxcap/body/skeleton.hpp"

namespace vc::body {

enum class BvhChannel { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

struct BvhClip {
  // Offsets in file units. An "End Site" becomes a joint named "<parent>_end" with end_site = true.
  Skeleton skeleton;
  std::vector<std::vector<BvhChannel>> channels;  // per joint, in file order (empty for End Sites)
  std::vector<int> first_channel;                 // per joint: index of its first value in a frame
  int channel_count = 0;                          // values per frame
  int frames = 0;
  double frame_time_s = 0;       // as written in the file
  int frame_time_decimals = -1;  // digits after the point as written, -1 if none
  std::vector<double> values;    // frames * channel_count, row-major
  // Per joint: its position channels give the joint's position in the parent's frame, replacing
  // OFFSET on the axes they cover (as many exporters write six channels on every joint, each
  // frame repeating the bone), rather than adding to it. parse_bvh decides it per joint from the
  // values: absolute when they lie nearer the OFFSET than zero (summed over frames and position
  // channels); a joint without position channels, or a tie (OFFSET zero), adds.
  std::vector<char> positions_absolute;

  const double* frame_values(int frame) const {
    return values.data() + static_cast<std::size_t>(frame) * static_cast<std::size_t>(channel_count);
  }
  // Local rotations R = R_c1 * R_c2 * R_c3 (channels in the order written, degrees); the root's
  // position channels go to root_position and other joints' to translation (both added to the
  // OFFSET in forward kinematics; for positions_absolute joints the OFFSET is taken off first), all
  // multiplied by `scale` (file units -> metres). Axes stay the file's. Throws std::out_of_range
  // for a bad frame.
  Pose pose(int frame, double scale = 1.0) const;
  // The skeleton with offsets multiplied by scale.
  Skeleton scaled_skeleton(double scale) const;
};

// Limits of the reader (a file beyond them is an error, never a huge allocation).
inline constexpr int kBvhMaxJoints = 4096;
inline constexpr long kBvhMaxFrames = 50'000'000;
inline constexpr double kBvhMaxMagnitude = 1e10;  // largest |value| of an offset, position or angle
inline constexpr std::size_t kBvhMaxFileBytes = std::size_t{1} << 30;  // read_bvh: 1 GiB (hours of motion)

// Parses BVH text. Throws std::runtime_error("<source_name>:<line>: <what>") on malformed input
// (including NaN, inf and out-of-range numbers); never reads out of bounds, whatever the bytes.
BvhClip parse_bvh(std::string_view text, const std::string& source_name = "bvh");
// Reads and parses a file; errors name the path. Only a regular file of at most kBvhMaxFileBytes is
// read: a FIFO, a device or a directory is refused at once (opened O_NONBLOCK, checked with fstat).
BvhClip read_bvh(const std::string& path);

// How poses are written. The file's axes: p_file = R_file_from_world * p_world, in file units
// (units_per_metre * metres); every local rotation is conjugated accordingly, so the file's own
// forward kinematics gives R_file_from_world * p_world * units_per_metre for every joint.
struct BvhWriteOptions {
  glm::dmat3 R_file_from_world{1.0};  // identity: the skeleton's own axes
  double units_per_metre = 1.0;       // 1: metres, 100: centimetres
  // Joint names in the file: the skeleton's, or for a standard skeleton (is_standard) the
  // MotionBuilder/Mixamo names of joint_bvh_name.
  bool standard_names = false;
  // Digits after the point for offsets, positions and angles: 8 keeps joint positions of a
  // round trip within 1e-7 m (metres, chains of ~10 joints) and angles within 1e-8 degrees.
  int decimals = 8;

  bool valid(std::string* why) const;
  // What Blender's BVH importer expects with its defaults (forward -Z, up Y): Y up, the
  // performer facing +Z; p_file = (x, z, -y) of the world (z up, facing -y); metres, standard
  // joint names. Blender shows the result in the world frame itself.
  static BvhWriteOptions blender();
};

// Writes poses of `skeleton` as BVH: joints with end_site = true become End Sites (a joint with
// no children gets a zero End Site), the root gets "Xposition Yposition Zposition Zrotation
// Yrotation Xrotation", every other joint "Zrotation Yrotation Xrotation" (local R = Rz * Ry * Rx,
// degrees); offsets and positions in file units. Pose translations on non-root joints are not
// representable and must be empty or zero. Throws std::invalid_argument otherwise.
std::string format_bvh(const Skeleton& skeleton, const std::vector<Pose>& poses, double frame_time_s,
                       const BvhWriteOptions& options = {});
void write_bvh(const std::string& path, const Skeleton& skeleton, const std::vector<Pose>& poses,
               double frame_time_s, const BvhWriteOptions& options = {});

}  // namespace vc::body
