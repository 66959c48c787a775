// The real BVH clips of the shared data folder (../shared/data beside the source tree), found by
// listing it: every *.bvh (any case) in it and its sub-folders, sorted. Tests that need clips fail
// with no_clips_message() when there are none; nothing here names a clip. For tests that check a
// clip's documented facts (data/README.md), find_clip looks a file name up in the listing.
// VOXCAP_SHARED_DIR comes from vc_test (deploy/cmake/VoxcapHelpers.cmake).
#pragma once

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace vc::body::testing {

inline std::filesystem::path shared_data_dir() {
  return std::filesystem::path(VOXCAP_SHARED_DIR) / "data";
}

inline bool is_bvh(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".bvh";
}

inline std::vector<std::filesystem::path> shared_bvh_clips() {
  namespace fs = std::filesystem;
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(shared_data_dir(), ec)) return out;
  for (auto it = fs::recursive_directory_iterator(shared_data_dir(),
                                                  fs::directory_options::follow_directory_symlink, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_regular_file(ec) && is_bvh(it->path())) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

inline std::string no_clips_message() {
  return "no *.bvh clips under " + shared_data_dir().string() +
         " (the shared data folder beside the source tree; see its README.md)";
}

// The listed clip whose file name is `name`, or an empty path.
inline std::filesystem::path find_clip(const std::vector<std::filesystem::path>& clips,
                                       const std::string& name) {
  for (const auto& p : clips) {
    if (p.filename() == name) return p;
  }
  return {};
}

// How many *.bvh files the folder's checksum list (SHA256SUMS.txt) names; -1 without the list.
inline int checksummed_bvh_count() {
  std::ifstream f(shared_data_dir() / "SHA256SUMS.txt");
  if (!f) return -1;
  int n = 0;
  for (std::string line; std::getline(f, line);) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.size() > 4 && is_bvh(std::filesystem::path(line.substr(line.find_last_of(" *") + 1)))) ++n;
  }
  return n;
}

}  // namespace vc::body::testing
