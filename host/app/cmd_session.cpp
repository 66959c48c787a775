// `voxcap session info DIR [--json] [--strict]`: what a recorded session holds (host/record).
// `voxcap session dump DIR [--type T] [--limit N] [--json]`: its records, one line each.
// A cut session is not an error: it is read up to its last complete record and says so.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "voxcap/aggregator/aggregator.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/pipeline/frame.hpp"
#include "voxcap/proto.h"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/record/session_info.hpp"

namespace vc::cli {
namespace {

namespace fs = std::filesystem;
using record::Reader;

Reader open_session(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw UsageError(fmt::format("{}: no such session folder", dir));
  if (!fs::exists(fs::path(dir) / "records.vcr", ec))
    throw UsageError(fmt::format("{}: not a voxcap session (no records.vcr)", dir));
  try {
    return Reader::open(dir);
  } catch (const std::runtime_error& e) {  // records.vcr a FIFO, a device, unreadable: bad input
    throw UsageError(e.what());
  }
}

// The rig's names of the node ids, from the [[nodes]] of the session's copy of rig.toml and the
// aggregator's numbering rule. A name that does not map is left out: the ids alone are still right.
record::NodeNames node_names(const Reader::Summary& s) {
  record::NodeNames names;
  for (size_t k = 0; k < s.rig_node_ids.size(); ++k) {
    config::NodeConfig node;
    node.id = s.rig_node_ids[k];
    try {
      names[config::node_number(node, k, "rig.toml")] = node.id;
    } catch (const std::exception&) {
    }
  }
  return names;
}

struct InfoArgs {
  std::string dir;
  bool json = false;
  bool strict = false;
};

void run_info(const InfoArgs& a) {
  const Reader reader = open_session(a.dir);
  const Reader::Summary& s = reader.summary_ref();
  const record::NodeNames names = node_names(s);
  const std::string out =
      a.json ? record::summary_json(s, a.dir, names) : record::summary_text(s, a.dir, names);
  std::fputs(out.c_str(), stdout);
  if (a.strict) {
    if (!s.closed_cleanly || s.truncated_bytes > 0)
      throw std::runtime_error(
          fmt::format("{}: session is {} ({})", a.dir, to_string(s.stop), s.stop_detail));
    if (!s.rig_toml_ok || !s.calibration_ok)
      throw std::runtime_error(fmt::format("{}: rig.toml or calibration.yaml does not verify", a.dir));
  }
}

// "head", "left_hand", ... for a vc_feature_id; "feature<N>" for anything else.
std::string feature_name(uint16_t id) {
  const char* n = vc_feature_name(id);
  return n ? std::string(n) : fmt::format("feature{}", id);
}

struct DumpArgs {
  std::string dir;
  std::string type;
  uint64_t limit = 0;
  bool json = false;
};

nlohmann::json to_json(const record::Record& r) {
  using nlohmann::json;
  return std::visit(
      [](const auto& x) -> json {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, record::FrameRecord>) {
          return {{"type", "frame"},
                  {"seq", x.seq},
                  {"t_trigger_ns", x.t_trigger_ns},
                  {"t_merged_ns", x.t_merged_ns},
                  {"grid_id", x.grid_id},
                  {"voxel_count", x.voxel_count},
                  {"occupied", x.occupied},
                  {"degraded", x.degraded},
                  {"nodes_present", x.nodes_present},
                  {"nodes_missing", x.nodes_missing},
                  {"rle_bytes", x.rle.size()}};
        } else if constexpr (std::is_same_v<T, record::FeatureRecord>) {
          json fs_json = json::array();
          for (const auto& f : x.features)
            fs_json.push_back(
                {{"id", f.id}, {"state", f.state}, {"u", f.u}, {"v", f.v}, {"confidence", f.confidence}});
          return {{"type", "features"},
                  {"seq", x.seq},
                  {"node_id", x.node_id},
                  {"camera", x.camera},
                  {"features", fs_json}};
        } else if constexpr (std::is_same_v<T, record::Features3DRecord>) {
          json fs_json = json::array();
          for (const auto& f : x.features) {
            json one = {
                {"id", f.id},
                {"name", feature_name(f.id)},
                {"state", pipeline::feature3d_state_name(static_cast<pipeline::Feature3DState>(f.state))},
                {"confidence", f.confidence},
                {"views", f.views}};
            if (f.state == 0) {
              one["p_world_m"] = {f.x, f.y, f.z};
              one["reproj_px"] = f.reproj_px;
            }
            if (f.id != 0) one["name_trusted"] = f.name_trusted;
            fs_json.push_back(one);
          }
          return {{"type", "features3d"}, {"seq", x.seq}, {"features", fs_json}};
        } else if constexpr (std::is_same_v<T, record::PoseRecord>) {
          pipeline::Pose p;
          std::string why;
          if (x.layout == record::kPoseLayout && record::from_record(x, &p, &why)) {
            json joints = json::object();
            for (int j = 0; j < pipeline::kPoseJointCount; ++j)
              joints[pipeline::pose_joint_name(j)] = p.p_world[static_cast<size_t>(j)];
            return {{"type", "pose"},
                    {"seq", x.seq},
                    {"layout", x.layout},
                    {"state", pipeline::pose_state_name(p.state)},
                    {"body_version", p.body_version},
                    {"confidence", p.confidence},
                    {"t_fitted_ns", p.t_fitted_ns},
                    {"torso_R_world", p.torso_R_world},
                    {"p_world_m", joints}};
          }
          json out = {{"type", "pose"},
                      {"seq", x.seq},
                      {"layout", x.layout},
                      {"joint_names", x.joint_names},
                      {"values", x.values}};
          if (x.layout == record::kPoseLayout) out["error"] = why;
          return out;
        } else {
          json body = json::parse(x.json, nullptr, false);
          if (body.is_discarded()) body = x.json;
          return {{"type", "stats"}, {"t_ns", x.t_ns}, {"node_id", x.node_id}, {"stats", body}};
        }
      },
      r);
}

std::string to_text(const record::Record& r) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, record::FrameRecord>) {
          return fmt::format(
              "frame    seq {:<8} trigger {} ns  merged +{:.2f} ms  {} of {} voxels occupied{}  nodes {} "
              "missing {}  rle {} B",
              x.seq, x.t_trigger_ns,
              x.t_merged_ns >= x.t_trigger_ns ? static_cast<double>(x.t_merged_ns - x.t_trigger_ns) / 1e6
                                              : -1.0,
              x.occupied, x.voxel_count, x.degraded ? " (degraded)" : "", fmt::join(x.nodes_present, ","),
              x.nodes_missing.empty() ? "-" : fmt::format("{}", fmt::join(x.nodes_missing, ",")),
              x.rle.size());
        } else if constexpr (std::is_same_v<T, record::FeatureRecord>) {
          std::string fs_text;
          for (const auto& f : x.features)
            fs_text +=
                fmt::format("  #{} ({:.1f}, {:.1f}) s{} c{:.2f}", f.id, f.u, f.v, f.state, f.confidence);
          return fmt::format("features seq {:<8} node {} camera {}:{}", x.seq, x.node_id, x.camera, fs_text);
        } else if constexpr (std::is_same_v<T, record::Features3DRecord>) {
          std::string fs_text;
          for (const auto& f : x.features) {
            if (f.state == 0)
              fs_text +=
                  fmt::format("  {} ({:.3f}, {:.3f}, {:.3f}) m c{:.2f}{} {:.1f} px cams {}",
                              feature_name(f.id), f.x, f.y, f.z, f.confidence,
                              f.name_trusted ? "" : " name-untrusted", f.reproj_px, fmt::join(f.views, ","));
            else
              fs_text +=
                  fmt::format("  {} {}", feature_name(f.id),
                              pipeline::feature3d_state_name(static_cast<pipeline::Feature3DState>(f.state)));
          }
          return fmt::format("features3d seq {:<8}{}", x.seq, fs_text);
        } else if constexpr (std::is_same_v<T, record::PoseRecord>) {
          pipeline::Pose p;
          std::string why;
          if (x.layout == record::kPoseLayout && record::from_record(x, &p, &why)) {
            std::string joints;
            if (p.valid())
              for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
                const auto& q = p.p_world[static_cast<size_t>(j)];
                joints += fmt::format("  {} ({:.3f}, {:.3f}, {:.3f})", pipeline::pose_joint_name(j), q[0],
                                      q[1], q[2]);
              }
            return fmt::format("pose     seq {:<8} {} body {} c{:.2f}{}", x.seq,
                               pipeline::pose_state_name(p.state), p.body_version, p.confidence, joints);
          }
          return fmt::format(
              "pose     seq {:<8} {} values ({}){}{}", x.seq, x.values.size(), x.layout,
              x.joint_names.empty() ? "" : fmt::format(", joints {}", fmt::join(x.joint_names, " ")),
              x.layout == record::kPoseLayout ? ": " + why : std::string());
        } else {
          return fmt::format(
              "stats    t {} ns node {}: {}", x.t_ns,
              x.node_id == record::kHostNodeId ? std::string("host") : std::to_string(x.node_id), x.json);
        }
      },
      r);
}

const char* type_name(const record::Record& r) {
  static const char* const kNames[] = {"frame", "features", "pose", "stats", "features3d"};
  return kNames[r.index()];
}

void run_dump(const DumpArgs& a) {
  if (!a.type.empty() && a.type != "frame" && a.type != "features" && a.type != "pose" && a.type != "stats" &&
      a.type != "features3d")
    throw UsageError(
        fmt::format("--type: must be frame, features, features3d, pose or stats, got \"{}\"", a.type));
  Reader reader = open_session(a.dir);
  record::Record r;
  uint64_t printed = 0;
  while ((a.limit == 0 || printed < a.limit) && reader.next(r)) {
    if (!a.type.empty() && a.type != type_name(r)) continue;
    const std::string line = a.json ? to_json(r).dump() : to_text(r);
    std::fputs(line.c_str(), stdout);
    std::fputc('\n', stdout);
    ++printed;
  }
  const Reader::Summary& s = reader.summary_ref();
  if (!a.json && !s.closed_cleanly && (a.limit == 0 || printed < a.limit))
    fmt::print(stderr, "voxcap: {}: session {} ({}); {} bytes ignored\n", a.dir, to_string(s.stop),
               s.stop_detail, s.truncated_bytes);
}

}  // namespace

void add_session_commands(CLI::App& app) {
  CLI::App* session =
      app.add_subcommand("session", "Inspect recorded sessions (folders written by voxcap-host)");
  session->require_subcommand(1, 1);

  auto info_args = std::make_shared<InfoArgs>();
  CLI::App* info = session->add_subcommand(
      "info",
      "Print what a session holds: rig, start time, frames (degraded, seq range, gaps), duration, features, "
      "poses, stats, nodes, and whether it was closed cleanly or cut (torn bytes ignored)");
  info->add_option("DIR", info_args->dir, "Session folder (holds records.vcr and session.json)")->required();
  info->add_flag("--json", info_args->json,
                 "Print one JSON object instead of text (keys: host/record/README.md)");
  info->add_flag("--strict", info_args->strict,
                 "Exit 1 unless the session was closed cleanly with no ignored bytes and its rig.toml and "
                 "calibration.yaml copies match their checksums");
  info->callback([info_args] { run_info(*info_args); });

  auto dump_args = std::make_shared<DumpArgs>();
  CLI::App* dump = session->add_subcommand("dump",
                                           "Print a session's records in file order, one line each "
                                           "(up to its last complete record)");
  dump->add_option("DIR", dump_args->dir, "Session folder")->required();
  dump->add_option("--type", dump_args->type,
                   "Only records of this type: frame, features, features3d (the host's triangulated "
                   "features), pose (the fitted skeleton: state, body version, the 15 joints in metres) or "
                   "stats");
  dump->add_option("--limit", dump_args->limit, "Stop after printing this many records (0: all)");
  dump->add_flag("--json", dump_args->json,
                 "One JSON object per line (hull RLE given as its size, rle_bytes)");
  dump->callback([dump_args] { run_dump(*dump_args); });
}

}  // namespace vc::cli
