// The fitted skeleton's figures against the virtual rig's truth, as voxcap eval --json names them and as
// voxcap demo prints them; shared by the live run (cmd_demo.cpp) and the offline score of a recorded
// session (voxcap fit SESSION --score, cmd_fit.cpp). Also the session's `virtual_rig.json`: what the
// virtual rig rendered (motion, BVH scale, seed, noise, presets, rate) and the run's origin seq, which
// voxcap demo writes beside the recording so that the session can be scored again without the rig.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/emulated/pose_scorer.hpp"

namespace vc::cli {

// The pose keys of voxcap eval --json (mpjpe_mm ... latency_ms); the caller adds rig, drops, wall time.
inline nlohmann::json pose_figures_json(const emulated::PoseAccuracy& p) {
  nlohmann::json per_joint = nlohmann::json::object();
  for (int j = 0; j < pipeline::kPoseJointCount; ++j)
    per_joint[pipeline::pose_joint_name(j)] = p.per_joint_mm[static_cast<size_t>(j)];
  return {{"mpjpe_mm", p.mpjpe_mm},
          {"per_joint_mm", per_joint},
          {"pa_mpjpe_mm", p.pa_mpjpe_mm},
          {"max_joint_mm", p.max_joint_mm},
          {"frames", p.frames},
          {"fitted_frames", p.fitted_frames},
          {"init_frames", p.init_frames},
          {"merged_frames", p.merged_frames},
          {"scored_frames", p.scored_frames},
          {"frames_outside_volume", p.frames_outside_volume},
          {"arm_in_torso_frames", p.arm_in_torso_frames},
          {"predicted_frames", p.predicted_frames},
          {"reinitialized_frames", p.reinitialized_frames},
          {"fps", p.fps},
          {"latency_ms", {{"p50", p.latency_p50_ms}, {"p99", p.latency_p99_ms}, {"max", p.latency_max_ms}}}};
}

// The figures as voxcap demo prints them (frames, speed, accuracy, per joint); `rate_hz` the trigger's.
// `latency` names what the latency is ("trigger -> pose" live, "fit" offline).
inline void print_pose_figures(const emulated::PoseAccuracy& p, double rate_hz,
                               const char* latency = "trigger -> pose") {
  fmt::print(
      "frames      {} merged, {} initialization, {} from the first pose: {} fitted ({} predicted, {} "
      "re-initialized)\n",
      p.merged_frames, p.init_frames, p.frames, p.fitted_frames, p.predicted_frames, p.reinitialized_frames);
  fmt::print(
      "speed       {:.1f} poses/s at {} Hz; {} p50 {:.1f} ms, p99 {:.1f} ms, max {:.1f} ms "
      "(frame period {:.1f} ms)\n",
      p.fps, rate_hz, latency, p.latency_p50_ms, p.latency_p99_ms, p.latency_max_ms, 1e3 / rate_hz);
  fmt::print(
      "accuracy    MPJPE {:.1f} mm, PA-MPJPE {:.1f} mm, worst joint {:.0f} mm over {} frames ({} with part "
      "of the body outside the volume, left out); arm inside the torso on {} frames\n",
      p.mpjpe_mm, p.pa_mpjpe_mm, p.max_joint_mm, p.scored_frames, p.frames_outside_volume,
      p.arm_in_torso_frames);
  std::string joints;
  for (int j = 0; j < pipeline::kPoseJointCount; ++j)
    joints += fmt::format(" {} {:.0f}", pipeline::pose_joint_name(j), p.per_joint_mm[static_cast<size_t>(j)]);
  fmt::print("per joint  {} (mm)\n", joints);
}

// The session's virtual_rig.json (written by voxcap demo beside records.vcr).
inline constexpr const char* kVirtualRigFile = "virtual_rig.json";
struct VirtualRig {
  emulated::Options rig;  // motion (a BVH's absolute path), bvh_scale, seed, noise, presets, rate, nodes
  uint64_t origin = 0;    // the seq of the virtual rig's frame 0
  uint64_t frames = 0;    // frames asked for
  nlohmann::json live;    // the live run's figures (pose_figures_json)
};
inline void write_virtual_rig(const std::filesystem::path& session, const VirtualRig& v) {
  const emulated::Options& o = v.rig;
  std::error_code ec;
  std::string motion = o.motion;
  if (std::filesystem::is_regular_file(motion, ec)) motion = std::filesystem::absolute(motion).string();
  const nlohmann::json j = {{"motion", motion},
                            {"bvh_scale", o.bvh_scale},
                            {"seed", o.seed},
                            {"noise", o.noise},
                            {"appearance", o.appearance},
                            {"room", o.room},
                            {"rate_hz", o.rate_hz},
                            {"nodes", o.nodes},
                            {"width", o.width},
                            {"height", o.height},
                            {"grid", o.grid},
                            {"origin", v.origin},
                            {"frames", v.frames},
                            {"live", v.live}};
  const std::filesystem::path p = session / kVirtualRigFile;
  std::ofstream f(p);
  f << j.dump(2) << "\n";
  if (!f) throw std::runtime_error(fmt::format("{}: cannot write", p.string()));
}

// Throws std::runtime_error (missing file, bad JSON, a value out of range) with one line.
inline VirtualRig read_virtual_rig(const std::filesystem::path& session) {
  const std::filesystem::path p = session / kVirtualRigFile;
  std::error_code ec;
  const auto size = std::filesystem::file_size(p, ec);
  if (ec)
    throw std::runtime_error(
        fmt::format("{}: {} (a session recorded by voxcap demo has it; only those can be scored)", p.string(),
                    ec.message()));
  if (size > 1 << 20) throw std::runtime_error(fmt::format("{}: larger than 1 MiB", p.string()));
  std::ifstream f(p);
  const nlohmann::json j = nlohmann::json::parse(f, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) throw std::runtime_error(fmt::format("{}: not a JSON object", p.string()));
  VirtualRig v;
  try {
    emulated::Options& o = v.rig;
    o.motion = j.at("motion").get<std::string>();
    o.bvh_scale = j.at("bvh_scale").get<double>();
    o.seed = j.at("seed").get<uint64_t>();
    o.noise = j.at("noise").get<double>();
    o.appearance = j.at("appearance").get<std::string>();
    o.room = j.at("room").get<std::string>();
    o.rate_hz = j.at("rate_hz").get<double>();
    o.nodes = j.at("nodes").get<int>();
    o.width = j.at("width").get<int>();
    o.height = j.at("height").get<int>();
    o.grid = j.at("grid").get<int>();
    v.origin = j.at("origin").get<uint64_t>();
    v.frames = j.at("frames").get<uint64_t>();
    v.live = j.value("live", nlohmann::json::object());
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(fmt::format("{}: {}", p.string(), e.what()));
  }
  std::string why;
  if (!v.rig.valid(&why)) throw std::runtime_error(fmt::format("{}: {}", p.string(), why));
  return v;
}

}  // namespace vc::cli
