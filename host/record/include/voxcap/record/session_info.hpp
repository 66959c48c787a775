// What `voxcap session info` prints about a session, as text for people and as JSON for scripts.
// Kept in the library (not in the command) so tests check exactly what users see.
#pragma once

#include <filesystem>
#include <string>

#include "voxcap/record/recorder.hpp"

namespace vc::record {

// Multi-line, aligned text ending in a newline: rig, created, frames (degraded, seq range, gaps),
// duration from trigger times, hulls, features, poses, stats, nodes, how the session ended.
std::string summary_text(const Reader::Summary& summary, const std::filesystem::path& dir);

// The same as a pretty-printed JSON object (keys documented in host/record/README.md), newline-terminated.
std::string summary_json(const Reader::Summary& summary, const std::filesystem::path& dir);

}  // namespace vc::record
