// Reading a file a user hands us (rig.yaml, rig.toml, edge.toml, a BVH, a session's manifest): regular
// files only, opened O_NONBLOCK and checked with fstat, so a FIFO, a device or a directory named by
// mistake is refused at once instead of hanging the reader; and a size limit, checked before and while
// reading, so a huge file fails with one line before it is parsed.
#pragma once

#include <cstddef>
#include <string>

namespace vc::rig {

// The whole file as bytes. Throws std::runtime_error("PATH: not a regular file (a FIFO)"),
// ("PATH: larger than N bytes"), ("PATH: cannot open: <strerror>") and the like.
std::string read_input_file(const std::string& path, std::size_t max_bytes);

// What a rig.yaml may hold: a real calibration of 8 cameras is about 10 KB.
inline constexpr std::size_t kMaxCalibrationBytes = std::size_t{4} << 20;

}  // namespace vc::rig
