// What `voxcap session info` prints about a session, as text for people and as JSON for scripts.
// Kept in the library (not in the command) so tests check exactly what users see.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "voxcap/record/recorder.hpp"

namespace vc::record {

// Node id -> the rig's name for it ("node0"), when the caller could read the session's rig.toml.
using NodeNames = std::map<uint16_t, std::string>;

// Multi-line, aligned text ending in a newline: rig, created, frames (degraded, seq range, gaps),
// duration from trigger times, hulls, features, poses, stats, nodes, how the session ended.
std::string summary_text(const Reader::Summary& summary, const std::filesystem::path& dir,
                         const NodeNames& node_names = {});

// The same as a pretty-printed JSON object (keys documented in host/record/README.md), newline-terminated.
std::string summary_json(const Reader::Summary& summary, const std::filesystem::path& dir,
                         const NodeNames& node_names = {});

// What a run's summary (voxcap rig, voxcap-host, voxcap demo) says of the session it recorded: the
// session read back with the Reader once the recorder closed it, so the summary counts exactly what
// the session holds — damaged records the reader had to skip included (issue #13) — and says when
// that is not every frame the run merged.
struct RunRecording {
  std::filesystem::path dir;
  uint64_t merged_frames = 0;                       // frames the run merged (its Report), for comparison
  uint64_t frames = 0;                              // FRAME records the reader took
  uint64_t records = 0;                             // data records the reader took
  uint64_t skipped_records = 0, skipped_bytes = 0;  // damage passed over (Reader::Summary)
  uint64_t truncated_bytes = 0;                     // a torn or corrupt tail ignored
  bool closed_cleanly = false;
  std::string stop;  // "closed", "cut", "torn", "corrupt"
  std::vector<std::string> damage;
  // Merged frames that the session does not hold (0 when it holds them all).
  uint64_t frames_not_recorded() const { return merged_frames > frames ? merged_frames - frames : 0; }
  // Whether the session holds every merged frame, whole: closed cleanly, nothing skipped or cut off.
  bool complete() const {
    return closed_cleanly && skipped_records == 0 && truncated_bytes == 0 && frames_not_recorded() == 0;
  }
};

// Reads the session in dir back (Reader::open; throws std::runtime_error as it does).
RunRecording read_back(const std::filesystem::path& dir, uint64_t merged_frames);
RunRecording read_back(const Reader::Summary& summary, const std::filesystem::path& dir,
                       uint64_t merged_frames);

// One line, e.g. "session   /x/rig-2026...: 600 frames (of 600 merged), 3012 records, closed cleanly";
// with damage "..., 1 damaged record skipped (4.9 KiB), 1 merged frame NOT in the session".
std::string run_recording_line(const RunRecording& r);

}  // namespace vc::record
