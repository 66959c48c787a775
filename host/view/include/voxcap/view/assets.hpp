// Where the viewer's page (index.html, app.js, protocol.js, style.css, lib/three.module.js,
// lib/OrbitControls.js) is found when rig.toml [viewer] assets does not say. The install layout puts the
// programs in <prefix>/bin and the page in <prefix>/share/voxcap/web (CMAKE_INSTALL_DATADIR; the host's
// .deb: /usr/bin, /usr/share/voxcap/web); the build tree copies the page to <build>/share/voxcap/web
// beside <build>/bin. So the page is looked for relative to the running binary first, then, for a
// program that runs from elsewhere in the build tree (a test), in the build tree this was built in.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace vc::view {

struct AssetSearch {
  std::filesystem::path dir;                 // the first folder tried that holds index.html; empty: none
  std::vector<std::filesystem::path> tried;  // every folder looked in, in order
};

// <exe's folder>/<from_bin> (from_bin: the page's folder relative to the binaries' folder, e.g.
// "../share/voxcap/web"), then `build_tree` (when not empty). Paths are made lexically normal.
AssetSearch find_assets(const std::filesystem::path& exe, const std::filesystem::path& from_bin,
                        const std::filesystem::path& build_tree);
// find_assets for this process (/proc/self/exe) with this build's install layout and build tree.
AssetSearch find_assets();
// One line for a search that found nothing: where it looked and what to do.
std::string no_assets_message(const AssetSearch& search);

// find_assets().dir, or the first folder tried when none holds the page (the error then names it).
std::filesystem::path default_assets_dir();

}  // namespace vc::view
