// A recorded session's own rig, for the commands that read a session on its own (`voxcap fit`,
// `voxcap view`): the session's rig.toml copy (the calibration file it names is not read: it may have
// moved or changed since the take), the grid from it or else from the session's calibration.yaml copy,
// and with `cameras` that calibration as the rig's. Bad copies: one line (UsageError, exit 2), prefixed
// with the command's name.
#pragma once

#include <exception>
#include <filesystem>
#include <string>

#include <fmt/core.h>

#include "commands.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::cli {

inline config::RigConfig session_rig(const std::filesystem::path& dir, const std::string& command,
                                     bool cameras) {
  config::RigConfig rig;
  try {
    config::LoadOptions lo;
    lo.load_calibration = false;
    rig = config::load_rig_config(dir / "rig.toml", lo);
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("{}: {}/rig.toml: {}", command, dir.string(), e.what()));
  }
  if (!cameras && rig.grid.nx > 0) return rig;
  rig::Calibration cal;
  try {
    cal = rig::read_calibration((dir / "calibration.yaml").string());
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("{}: {}/calibration.yaml: {}", command, dir.string(), e.what()));
  }
  if (rig.grid.nx <= 0) {
    if (!cal.grid)
      throw UsageError(
          fmt::format("{}: {}: neither rig.toml nor calibration.yaml has a grid", command, dir.string()));
    rig.grid = *cal.grid;
  }
  if (cameras) rig.calibration = std::move(cal);
  return rig;
}

}  // namespace vc::cli
