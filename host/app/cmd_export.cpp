// `voxcap export SESSION --bvh take.bvh --csv joints.csv [--units m|cm] [--origin SEQ]`: a recorded
// session's fitted poses as BVH (hw/body's standard humanoid, rest T-pose with the fitted segment
// lengths) and joints.csv (frame,joint,x,y,z in metres, world frame), from one forward kinematics
// (host/export). Thin: read the poses, make the take, write, and say on stderr what was left out.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "export_report.hpp"
#include "voxcap/export/session_take.hpp"
#include "voxcap/export/take.hpp"

namespace vc::cli {

void report_take(const take::Take& t, const char* what) {
  if (t.before_first)
    fmt::print(stderr,
               "voxcap {}: {} frames before the first pose (initialization) left out: BVH frame 0 is "
               "frame {}\n",
               what, t.before_first, t.first_frame);
  if (t.after_last)
    fmt::print(stderr, "voxcap {}: {} frames after the last pose left out\n", what, t.after_last);
  if (t.held)
    fmt::print(
        stderr,
        "voxcap {}: {} frames without a pose ({} of them not recorded at all) hold the previous pose in "
        "the BVH and have no rows in joints.csv\n",
        what, t.held, t.missing);
  if (t.other_version_frames)
    fmt::print(
        stderr,
        "voxcap {}: the body model changed during the take; {} frames of other body versions are written "
        "with body version {}'s segment lengths (their bone directions kept)\n",
        what, t.other_version_frames, t.body_version);
}

namespace {

struct ExportArgs {
  std::string session;
  std::string bvh, csv;
  std::string units = "m";
  int64_t origin = -1;
};

void run_export(const ExportArgs& a) {
  if (a.bvh.empty() && a.csv.empty()) throw UsageError("export: give --bvh FILE, --csv FILE or both");
  if (a.units != "m" && a.units != "cm")
    throw UsageError("export: --units must be m or cm, got '" + a.units + "'");
  std::error_code ec;
  if (!std::filesystem::is_directory(a.session, ec))
    throw UsageError(fmt::format("export: {}: no such session folder", a.session));
  if (!std::filesystem::exists(std::filesystem::path(a.session) / "records.vcr", ec))
    throw UsageError(fmt::format("export: {}: not a voxcap session (no records.vcr)", a.session));
  const take::SessionPoses s = take::read_session_poses(
      a.session, a.origin >= 0 ? std::optional<uint64_t>(static_cast<uint64_t>(a.origin)) : std::nullopt);
  for (const std::string& w : s.warnings) fmt::print(stderr, "voxcap export: {}\n", w);
  if (s.bad_poses)
    fmt::print(stderr, "voxcap export: {} pose records did not decode and were left out\n", s.bad_poses);
  if (s.posed == 0)
    throw std::runtime_error(
        fmt::format("export: {} has no fitted poses ({} frames, {} pose records): was the fitting stage on? "
                    "`voxcap fit {} --out DIR` fits it offline",
                    a.session, s.frame_records, s.pose_records, a.session));
  const take::Take t = take::make_take(s.frames);
  report_take(t, "export");
  take::WriteOptions wo;
  wo.frame_time_s = s.frame_time_s;
  wo.units_per_metre = a.units == "cm" ? 100.0 : 1.0;
  if (!a.bvh.empty()) take::write_bvh(a.bvh, t, wo);
  uint64_t rows = 0;
  if (!a.csv.empty()) rows = take::write_joints_csv(a.csv, t);
  fmt::print("{} frames ({} .. {}), frame time {:.6f} s ({}), body version {}{}{}\n", t.poses.size(),
             t.first_frame, t.first_frame + static_cast<int64_t>(t.poses.size()) - 1, wo.frame_time_s,
             s.frame_time_source, t.body_version,
             a.bvh.empty() ? "" : fmt::format(", {} ({})", a.bvh, a.units),
             a.csv.empty() ? "" : fmt::format(", {} ({} rows)", a.csv, rows));
}

}  // namespace

void add_export_commands(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write a recorded session's fitted poses as BVH (standard humanoid rooted at Hips, Blender's axes: Y "
      "up, "
      "facing +Z; rest T-pose with the fitted segment lengths) and/or joints.csv "
      "(frame,joint,x,y,z,state,fitted; "
      "metres, world frame, z up; joint names as in the BVH), both from the same forward kinematics. Frames "
      "before the first pose are left out; frames without a pose hold the previous pose in the BVH and have "
      "no rows in joints.csv (counted on stderr)");
  cmd->add_option("SESSION", args->session, "Session folder (voxcap-host, voxcap rig --record, voxcap demo)")
      ->required();
  cmd->add_option("--bvh", args->bvh, "Write the BVH here");
  cmd->add_option("--csv", args->csv, "Write joints.csv here");
  cmd->add_option("--units", args->units, "BVH units: m (default) or cm; joints.csv is always in metres");
  cmd->add_option(
      "--origin", args->origin,
      "The seq of frame 0 (default: the session's first frame; the emulated rig's first frame is the "
      "virtual rig's frame 0)");
  cmd->callback([args] { run_export(*args); });
}

}  // namespace vc::cli
