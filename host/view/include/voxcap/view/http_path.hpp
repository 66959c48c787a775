// What the viewer's HTTP server makes of a request target, before any file is touched: the one place a
// browser's path becomes a file name. Everything a browser sends is taken as hostile: the target is
// bounded, percent-decoded once, and refused when any segment is empty-dot, "..", hidden, or holds a
// byte outside a small safe set; the file found must then lie inside the asset folder after symlinks
// are resolved (Server checks that) and be a regular file of bounded size.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace vc::view {

inline constexpr size_t kMaxTarget = 1024;           // bytes of a request target
inline constexpr size_t kMaxAssetBytes = 16u << 20;  // the largest file served

// "/" → "index.html", "/lib/three.module.js?v=1" → "lib/three.module.js". False (and why) for a
// target that is not an absolute path, too long, badly percent-encoded, or names anything outside the
// folder or hidden.
bool resolve_target(std::string_view target, std::string* relative, std::string* why);

// The Content-Type for a file name's extension; "application/octet-stream" for an unknown one.
std::string_view mime_type(std::string_view path);

// The file `relative` (from resolve_target) inside `root`, with symlinks resolved: false when it is not
// inside root, not a regular file, or larger than kMaxAssetBytes.
bool asset_file(const std::filesystem::path& root, const std::string& relative, std::filesystem::path* out,
                std::string* why);

}  // namespace vc::view
