#include "truth_session.hpp"

#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "voxcap/body/joints.hpp"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::testing {

void write_truth_session(const std::filesystem::path& dir, const TruthSessionOptions& o) {
  const std::filesystem::path parent = dir.parent_path();
  std::filesystem::create_directories(parent);
  const auto rig_toml = parent / (dir.filename().string() + "-rig.toml");
  const auto cal = parent / (dir.filename().string() + "-rig.yaml");
  std::ofstream(rig_toml) << fmt::format("name = \"truth\"\n[trigger]\nrate_hz = {}\n", o.rate_hz);
  std::ofstream(cal) << "%YAML:1.0\n";
  record::Recorder rec = record::Recorder::create(dir, rig_toml, cal, R"({"source":"hw/sim truth"})");
  sim::SceneOptions so;
  so.motion.source = o.motion;
  so.motion.fps = o.rate_hz;
  const sim::Scene scene(so);
  record::FrameRecord fr;
  record::PoseRecord pr;
  for (int f = 0; f < o.frames; ++f) {
    fr.seq = o.first_seq + static_cast<uint64_t>(f);
    fr.t_trigger_ns = 5'000'000'000ull + static_cast<uint64_t>(double(f) * 1e9 / o.rate_hz);
    fr.t_merged_ns = fr.t_trigger_ns + 3'000'000;
    rec.append(fr);
    pipeline::Pose p;
    p.t_fitted_ns = fr.t_merged_ns + 1'000'000;
    if (f >= o.init_frames && !o.no_pose.count(f)) {
      p.state = pipeline::PoseState::Fitted;
      p.body_version = 1;
      p.confidence = 1;
      const auto truth = scene.joints(f);
      for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
        const cv::Vec3d& v = truth[static_cast<size_t>(body::joint_from_name(pipeline::pose_joint_name(j)))];
        p.p_world[static_cast<size_t>(j)] = {v[0], v[1], v[2]};
      }
    }
    record::to_record(fr.seq, p, f == 0, &pr);
    rec.append(pr);
  }
  rec.close();
}

CommandResult run(const std::string& command, const std::filesystem::path& scratch) {
  const auto out = scratch / "run.out", err = scratch / "run.err";
  const int status = std::system((command + " >'" + out.string() + "' 2>'" + err.string() + "'").c_str());
  CommandResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::filesystem::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

JointsCsv read_joints_csv(const std::filesystem::path& path) {
  JointsCsv c;
  std::ifstream in(path);
  std::getline(in, c.header);
  std::string line;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string frame, joint, x, y, z, state;
    std::getline(ss, frame, ',');
    std::getline(ss, joint, ',');
    std::getline(ss, x, ',');
    std::getline(ss, y, ',');
    std::getline(ss, z, ',');
    std::getline(ss, state, ',');
    const int64_t f = std::stoll(frame);
    c.p[f][joint] = {std::stod(x), std::stod(y), std::stod(z)};
    c.state[f] = state;
    ++c.rows;
  }
  return c;
}

glm::dvec3 true_joint(const std::string& motion, double rate_hz, int f, const std::string& joint) {
  sim::SceneOptions so;
  so.motion.source = motion;
  so.motion.fps = rate_hz;
  static std::map<std::pair<std::string, double>, std::unique_ptr<sim::Scene>> scenes;
  auto& scene = scenes[{motion, rate_hz}];
  if (!scene) scene = std::make_unique<sim::Scene>(so);
  const cv::Vec3d v = scene->joints(f)[static_cast<size_t>(body::joint_from_name(joint))];
  return {v[0], v[1], v[2]};
}

}  // namespace vc::testing
