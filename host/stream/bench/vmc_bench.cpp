// The VMC stage's cost per frame (Google Benchmark; figures only, nothing asserted):
//   BM_VmcPose         a fitted pose -> the 19 bones in Unity's frame (VmcPoser::pose)
//   BM_VmcStageMemory  VmcStage::process of a posed frame, the bundle handed to the in-memory twin
//                      (pose + the stage's own work, no OSC)
//   BM_VmcStageLiblo   the same with liblo: the OSC bundle built and sent over UDP to 127.0.0.1 (a socket
//                      that is never read: the kernel drops what overflows it, as for a receiver behind)
// Run: build/<preset>/bin/vc_vmc_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <stdexcept>
#include <vector>

#include "voxcap/body/joints.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/stream/vmc_stage.hpp"

namespace {

using namespace vc;

// A standard body at rest, its arms turned a little more every frame: distinct rotations per frame.
std::vector<pipeline::Pose> poses(int n) {
  body::StandardSegments seg;
  seg.hips_to_spine_m = 0.01;
  const body::Skeleton sk = body::standard_skeleton(seg);
  std::vector<pipeline::Pose> out;
  for (int k = 0; k < n; ++k) {
    body::Pose bp = body::rest_pose(sk, {0.01 * k, 0, 0.95});
    bp.local[static_cast<size_t>(body::Joint::l_shoulder)] = body::rot_y(0.02 * k);
    bp.local[static_cast<size_t>(body::Joint::r_elbow)] = body::rot_z(0.5 + 0.01 * k);
    bp.local[static_cast<size_t>(body::Joint::l_knee)] = body::rot_x(0.3);
    std::vector<glm::dvec3> p;
    body::forward_kinematics(sk, bp, &p);
    pipeline::Pose pose;
    pose.state = pipeline::PoseState::Fitted;
    pose.body_version = 1;
    for (int j = 0; j < pipeline::kPoseJointCount; ++j) {
      const glm::dvec3& q = p.at(static_cast<size_t>(body::joint_from_name(pipeline::pose_joint_name(j))));
      pose.p_world[static_cast<size_t>(j)] = {q.x, q.y, q.z};
    }
    out.push_back(pose);
  }
  return out;
}

void BM_VmcPose(benchmark::State& state) {
  const std::vector<pipeline::Pose> ps = poses(64);
  stream::VmcPoser poser;
  size_t k = 0;
  for ([[maybe_unused]] auto _ : state) {
    stream::VmcPose v = poser.pose(ps[k++ % ps.size()]);
    benchmark::DoNotOptimize(v);
  }
}
BENCHMARK(BM_VmcPose);

void run_stage(benchmark::State& state, std::unique_ptr<stream::VmcSink> sink) {
  const std::vector<pipeline::Pose> ps = poses(64);
  config::RigConfig rig;
  rig.trigger.rate_hz = 60;
  config::VmcOptions o;
  o.enabled = true;
  stream::VmcStage stage(o, std::move(sink));
  pipeline::StageContext ctx;
  ctx.rig = &rig;
  ctx.log = [](log::Level, const std::string&) {};
  stage.configure(ctx);
  pipeline::Frame f;
  for ([[maybe_unused]] auto _ : state) {
    f.pose = ps[f.seq % ps.size()];
    f.t_trigger_ns = f.seq * 16'666'667ULL;
    stage.process(f);
    ++f.seq;
  }
  const stream::VmcCounters c = stage.counters();
  state.counters["sent"] = static_cast<double>(c.sent);
  state.counters["errors"] = static_cast<double>(c.send_errors);
}

void BM_VmcStageMemory(benchmark::State& state) {
  run_stage(state, std::make_unique<stream::MemorySink>(0));
}
BENCHMARK(BM_VmcStageMemory);

void BM_VmcStageLiblo(benchmark::State& state) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0)
    throw std::runtime_error("bench: cannot bind 127.0.0.1");
  run_stage(state, stream::make_liblo_sink({"127.0.0.1", ntohs(a.sin_port)}));
  ::close(fd);
}
BENCHMARK(BM_VmcStageLiblo);

}  // namespace

BENCHMARK_MAIN();
