#include "voxcap/view/assets.hpp"

#include <system_error>

#include <fmt/format.h>

// Set by host/view/CMakeLists.txt: the page's install folder relative to the programs' one, and the
// build tree's copy of it.
#ifndef VC_WEB_FROM_BINDIR
#define VC_WEB_FROM_BINDIR "../share/voxcap/web"
#endif
#ifndef VC_WEB_BUILD_DIR
#define VC_WEB_BUILD_DIR ""
#endif

namespace vc::view {

AssetSearch find_assets(const std::filesystem::path& exe, const std::filesystem::path& from_bin,
                        const std::filesystem::path& build_tree) {
  AssetSearch s;
  if (!exe.empty()) s.tried.push_back((exe.parent_path() / from_bin).lexically_normal());
  if (!build_tree.empty()) {
    const std::filesystem::path b = build_tree.lexically_normal();
    if (s.tried.empty() || s.tried.front() != b) s.tried.push_back(b);
  }
  for (const std::filesystem::path& dir : s.tried) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(dir / "index.html", ec)) {
      s.dir = dir;
      break;
    }
  }
  return s;
}

AssetSearch find_assets() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return find_assets(ec ? std::filesystem::path() : exe, VC_WEB_FROM_BINDIR, VC_WEB_BUILD_DIR);
}

std::string no_assets_message(const AssetSearch& search) {
  std::string where;
  for (const std::filesystem::path& d : search.tried) where += (where.empty() ? "" : " nor ") + d.string();
  return fmt::format(
      "viewer: no page (index.html) in {}: build the voxcap_web target, install voxcap, or set rig.toml "
      "[viewer] assets",
      where.empty() ? std::string("any folder (the binary's path is unknown)") : where);
}

std::filesystem::path default_assets_dir() {
  const AssetSearch s = find_assets();
  if (!s.dir.empty()) return s.dir;
  return s.tried.empty() ? std::filesystem::path() : s.tried.front();
}

}  // namespace vc::view
