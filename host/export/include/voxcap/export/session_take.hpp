// The poses of a recorded session (host/record) as take frames: what `voxcap export` reads.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "voxcap/export/take.hpp"

namespace vc::take {

struct SessionPoses {
  std::vector<PosedFrame> frames;  // one per recorded frame (and per pose without a frame), by frame number
  int64_t origin = 0;              // the seq of frame number 0
  double frame_time_s = 0;         // [trigger] rate_hz of the session's rig.toml, else the trigger times
  std::string frame_time_source;   // "rig.toml", "trigger times" or "default 60 Hz"
  uint64_t frame_records = 0;      // FRAME records
  uint64_t pose_records = 0;       // POSE records of layout voxcap.pose15/1
  uint64_t posed = 0;              // of those, with a pose (state not none)
  uint64_t bad_poses = 0;          // POSE records of that layout that did not decode (counted, not used)
  uint64_t other_layouts = 0;      // POSE records of other layouts (not fitted skeletons; ignored)
  std::vector<std::string> warnings;
};

// Reads every record of the session at `dir` (a cut session up to its last complete record). Frame
// numbers are seq - origin, origin = `origin` if given, else the seq of the session's first frame
// record (the emulated rig's first frame is the virtual rig's frame 0). Throws std::runtime_error
// when DIR is not a session.
SessionPoses read_session_poses(const std::filesystem::path& dir, std::optional<uint64_t> origin = {});

}  // namespace vc::take
