// What `voxcap session info` prints about a session, as text for people and as JSON for scripts.
// Kept in the library (not in the command) so tests check exactly what users see.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

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

}  // namespace vc::record
