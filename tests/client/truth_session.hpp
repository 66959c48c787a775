// A recorded session whose poses are the virtual rig's true joints (hw/sim): what `voxcap export`
// reads in the export and Blender tests, made without running a rig. Frames seq = first_seq + f for the
// virtual rig's frames f = 0 .. frames-1; the first `init_frames` have a pose of state none (the
// fitter's initialization), and the frames in `no_pose` none either.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include <glm/vec3.hpp>

namespace vc::testing {

struct TruthSessionOptions {
  std::string motion = "wave";
  int frames = 120;
  int init_frames = 5;
  std::set<int> no_pose;
  uint64_t first_seq = 1000;
  double rate_hz = 50;  // [trigger] rate_hz of the session's rig.toml
};

// Writes the session folder `dir` (rig.toml and calibration stubs beside it in dir's parent).
void write_truth_session(const std::filesystem::path& dir, const TruthSessionOptions& options);

// A shell command's exit code (-1: did not exit), stdout and stderr.
struct CommandResult {
  int code = -1;
  std::string out, err;
};
CommandResult run(const std::string& command, const std::filesystem::path& scratch);

// joints.csv of voxcap export: frame -> joint -> position (and the header line, the states).
struct JointsCsv {
  std::string header;
  std::map<int64_t, std::map<std::string, glm::dvec3>> p;
  std::map<int64_t, std::string> state;
  size_t rows = 0;
};
JointsCsv read_joints_csv(const std::filesystem::path& path);

// The true joint (hw/body name, e.g. "l_wrist") of the motion's frame f at `rate_hz`.
glm::dvec3 true_joint(const std::string& motion, double rate_hz, int f, const std::string& joint);

}  // namespace vc::testing
