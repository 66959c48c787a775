// The run summary's account of its recording (voxcap rig, voxcap demo; voxcap-host prints the line):
// the session read back once it was closed (record::read_back), as the `session` object of --json.
#pragma once

#include <nlohmann/json.hpp>

#include "voxcap/record/session_info.hpp"

namespace vc::cli {

// {dir, frames, merged_frames, frames_not_recorded, records, skipped_records, skipped_bytes,
//  truncated_bytes, closed_cleanly, stop, damage[]}
inline nlohmann::json run_recording_json(const record::RunRecording& r) {
  return {{"dir", r.dir.string()},
          {"frames", r.frames},
          {"merged_frames", r.merged_frames},
          {"frames_not_recorded", r.frames_not_recorded()},
          {"records", r.records},
          {"skipped_records", r.skipped_records},
          {"skipped_bytes", r.skipped_bytes},
          {"truncated_bytes", r.truncated_bytes},
          {"closed_cleanly", r.closed_cleanly},
          {"stop", r.stop},
          {"damage", r.damage}};
}

}  // namespace vc::cli
