#include "host_bench.hpp"

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <thread>

#include "voxcap/assemble/assembler.hpp"
#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/fit/fitter.hpp"
#include "voxcap/fit/synthetic.hpp"
#include "voxcap/rle.h"
#include "voxcap/sim/motion.hpp"
#include "voxcap/sim/scene.hpp"
#include "voxcap/triangulate/synthetic.hpp"
#include "voxcap/triangulate/triangulate.hpp"

namespace vc::bench {
namespace {

using Clock = std::chrono::steady_clock;

// Body occupancy of the wave motion at a pose with the arms out, on an n^3 grid over the volume.
std::vector<uint8_t> body(int n) {
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.rig.cameras = 2;
  so.rig.width = 64;
  so.rig.height = 48;
  sim::Scene scene(so);
  rig::VoxelGrid g;
  g.min_m = cv::Vec3d(-1.12, -1.12, 0);
  g.voxel_m = 2.24 / n;
  g.nx = g.ny = g.nz = n;
  std::vector<uint8_t> bits;
  scene.occupancy(g, 100, &bits);
  return bits;
}

// The body extruded along direction angle (radians, horizontal): every voxel within `reach` metres of
// the body along +-d. Computed by OR-ing shifted copies, one voxel step at a time.
std::vector<uint8_t> extrude(const std::vector<uint8_t>& b, int n, double angle, double reach_m) {
  std::vector<uint8_t> out = b;
  double vox = 2.24 / n;
  int steps = static_cast<int>(reach_m / vox);
  double dx = std::cos(angle), dy = std::sin(angle);
  auto get = [&](int i, int j, int k) {
    size_t v = static_cast<size_t>(i) +
               static_cast<size_t>(n) * (static_cast<size_t>(j) + static_cast<size_t>(n) * k);
    return (b[v / 8] >> (v % 8)) & 1;
  };
  for (int k = 0; k < n; k++)
    for (int j = 0; j < n; j++)
      for (int i = 0; i < n; i++) {
        if (!get(i, j, k)) continue;
        for (int s = -steps; s <= steps; s++) {
          int ii = i + static_cast<int>(std::lround(s * dx)), jj = j + static_cast<int>(std::lround(s * dy));
          if (ii < 0 || jj < 0 || ii >= n || jj >= n) continue;
          size_t v = static_cast<size_t>(ii) +
                     static_cast<size_t>(n) * (static_cast<size_t>(jj) + static_cast<size_t>(n) * k);
          out[v / 8] |= static_cast<uint8_t>(1u << (v % 8));
        }
      }
  return out;
}

std::vector<uint8_t> encode(const std::vector<uint8_t>& bits, size_t nbits) {
  std::vector<uint8_t> out(vc_rle_max_encoded_size(nbits));
  size_t len = 0;
  vc_rle_encode(bits.data(), nbits, out.data(), out.size(), &len);
  out.resize(len);
  return out;
}

// Median and 99th percentile of a sample (sorted in place).
std::pair<double, double> median_p99(std::vector<double>& v) {
  if (v.empty()) return {0, 0};
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2], v[std::min(v.size() - 1, v.size() * 99 / 100)]};
}

nlohmann::json fit_bench(const HostBenchOptions& o) {
  sim::SceneOptions so;
  so.motion.source = o.fit_motion;
  so.rig.cameras = 4;
  so.rig.width = 64;
  so.rig.height = 48;
  so.rig.voxel_m = (so.rig.volume_max_m[0] - so.rig.volume_min_m[0]) / o.fit_grid;
  const sim::Scene scene(so);
  const rig::VoxelGrid grid = *scene.calibration().grid;
  const int frames = o.fit_frames > 0 ? o.fit_frames : scene.motion().natural_frames();
  // The frames first (true occupancy, RLE), so that only the fitting is timed.
  std::mt19937_64 rng(5);
  std::vector<pipeline::Frame> in;
  in.reserve(static_cast<size_t>(frames));
  for (int f = 0; f < frames; ++f) in.push_back(fit::testing::synthetic_frame(scene, grid, f, {}, rng));
  config::FittingOptions opt;  // the method's settings: 256 samples, 15 steps
  fit::Fitter fitter(grid, opt, 60);
  std::vector<double> decode, segment, pca, layer1, layer2, limb, total, err;
  for (int f = 0; f < frames; ++f) {
    const pipeline::Pose pose = fitter.fit(in[static_cast<size_t>(f)]);
    if (!pose.valid()) continue;
    const fit::StageTimes& t = fitter.times();
    decode.push_back(static_cast<double>(t.decode_ns) / 1e3);
    segment.push_back(static_cast<double>(t.segment_ns) / 1e3);
    pca.push_back(static_cast<double>(t.pca_ns) / 1e3);
    layer1.push_back(static_cast<double>(t.layer1_ns) / 1e3);
    double l2 = 0;
    for (size_t k = 0; k < t.layer2_ns.size(); ++k) {
      l2 += static_cast<double>(t.layer2_ns[k]) / 1e3;
      if (t.layer2_searched[k]) limb.push_back(static_cast<double>(t.layer2_ns[k]) / 1e3);
    }
    layer2.push_back(l2);
    total.push_back(static_cast<double>(t.total_ns) / 1e3);
    err.push_back(fit::testing::mpjpe(pose, fit::testing::true_pose(scene, f)));
  }
  const size_t fitted = total.size();
  double err_mean = 0;
  for (double e : err) err_mean += e / std::max<size_t>(1, err.size());
  auto stage = [](std::vector<double>& v) {
    const auto [m, p] = median_p99(v);
    return nlohmann::json{{"us", m}, {"us_p99", p}};
  };
  return {{"motion", o.fit_motion},
          {"grid", {grid.nx, grid.ny, grid.nz}},
          {"voxel_m", grid.voxel_m},
          {"samples", opt.samples},
          {"steps", opt.steps},
          {"frames", frames},
          {"fitted_frames", fitted},
          {"decode", stage(decode)},
          {"torso_segmentation", stage(segment)},
          {"pca", stage(pca)},
          {"layer1", stage(layer1)},
          {"layer2_segment", stage(limb)},
          {"layer2_all", stage(layer2)},
          {"total", stage(total)},
          {"mpjpe_mm", 1000 * err_mean},
          {"paper_table1_ms",
           {{"pca", 4.0}, {"torso_segmentation", 5.5}, {"layer1", 16.0}, {"layer2_segment", 211.0}}}};
}

}  // namespace

nlohmann::json run_host_bench(const HostBenchOptions& o) {
  nlohmann::json j;
  j["merge"] = nlohmann::json::array();
  for (int n : o.grids) {
    size_t nbits = static_cast<size_t>(n) * n * n;
    std::vector<uint8_t> b = body(n);
    int max_nodes = *std::max_element(o.nodes.begin(), o.nodes.end());
    std::vector<std::vector<uint8_t>> parts;
    parts.reserve(static_cast<size_t>(max_nodes));
    for (int k = 0; k < max_nodes; k++)
      parts.push_back(encode(extrude(b, n, M_PI * k / max_nodes, 1.0), nbits));
    for (int nodes : o.nodes) {
      std::vector<const std::vector<uint8_t>*> in;
      size_t rle_bytes = 0;
      for (int k = 0; k < nodes; k++) {
        in.push_back(&parts[static_cast<size_t>(k * max_nodes / nodes)]);
        rle_bytes += in.back()->size();
      }
      std::vector<uint8_t> out, scratch;
      assemble::intersect(in, out, scratch);  // warm-up: buffers sized
      std::vector<double> ns;
      for (int r = 0; r < o.repeats; r++) {
        auto t0 = Clock::now();
        assemble::intersect(in, out, scratch);
        ns.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count());
      }
      std::sort(ns.begin(), ns.end());
      uint64_t occ = 0, total = 0;
      vc_rle_popcount(out.data(), out.size(), &occ, &total);
      j["merge"].push_back({{"nodes", nodes},
                            {"grid", n},
                            {"voxels", nbits},
                            {"rle_bytes_per_node", rle_bytes / static_cast<size_t>(nodes)},
                            {"merged_occupied", occ},
                            {"merge_ns_per_frame", ns[ns.size() / 2]},
                            {"merge_ns_p99", ns[std::min(ns.size() - 1, ns.size() * 99 / 100)]}});
    }
  }
  j["triangulate"] = nlohmann::json::array();
  for (int cams : o.tri_cameras) {
    sim::SceneOptions so;
    so.motion.source = "wave";
    so.rig.cameras = cams;
    so.rig.distortion = true;
    const sim::Scene scene(so);
    std::mt19937_64 rng(7);
    triangulate::testing::Noise noise;
    noise.outlier = 0.05;
    std::vector<std::vector<triangulate::CameraObservations>> obs;
    obs.reserve(static_cast<size_t>(o.tri_frames));
    for (int f = 0; f < o.tri_frames; ++f) obs.push_back(triangulate::testing::observe(scene, f, noise, rng));
    triangulate::FeatureTriangulator tri(scene.calibration().cameras, {0, 1}, triangulate::Options{});
    std::vector<double> ns, err;
    for (int f = 0; f < o.tri_frames; ++f) {
      auto t0 = Clock::now();
      const auto r = tri.process(obs[static_cast<size_t>(f)]);
      ns.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count());
      for (int id = 0; id < 5; ++id)
        if (r[static_cast<size_t>(id)].state == pipeline::Feature3DState::Triangulated) {
          const auto& p = r[static_cast<size_t>(id)].p_world;
          err.push_back(cv::norm(cv::Vec3d(p[0], p[1], p[2]) - triangulate::testing::truth(scene, f, id)));
        }
    }
    std::sort(ns.begin(), ns.end());
    std::sort(err.begin(), err.end());
    j["triangulate"].push_back({{"cameras", cams},
                                {"frames", o.tri_frames},
                                {"ns_per_frame", ns[ns.size() / 2]},
                                {"ns_p99", ns[std::min(ns.size() - 1, ns.size() * 99 / 100)]},
                                {"err3d_mm_p50", err.empty() ? 0.0 : 1000 * err[err.size() / 2]}});
  }
  j["fit"] = fit_bench(o);
  if (o.rig) {
    emulated::Options eo;
    eo.nodes = o.rig_nodes;
    eo.width = o.width;
    eo.height = o.height;
    eo.grid = o.rig_grid;
    eo.truth_every = 0;
    emulated::EmulatedRig rig(eo);
    rig.start(120);
    long rss_start = emulated::rss_kb();
    auto t_run = Clock::now();
    rig.run_seconds(o.rig_minutes * 60);
    const aggregator::Report run = rig.report();  // the run's figures, before the rejoin below
    const double run_s = std::chrono::duration<double>(Clock::now() - t_run).count();
    // Rejoin: an edge killed (SIGKILL) and started again; the time from its start to RUNNING in the
    // run again (HELLO, CONFIG, background learnt, START with the run's origin).
    const int k = o.rig_nodes > 1 ? 1 : 0;
    rig.kill_node(k, SIGKILL);
    rig.run_seconds(0.5);
    auto t0 = Clock::now();
    rig.restart_node(k);
    while (!rig.node_running(k) && Clock::now() - t0 < std::chrono::seconds(30))
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    nlohmann::json rejoin_ms = nullptr;
    if (rig.node_running(k)) rejoin_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    emulated::Result r = rig.stop();
    j["rig"] = {{"nodes", o.rig_nodes},
                {"size", std::to_string(o.width) + "x" + std::to_string(o.height)},
                {"grid", o.rig_grid},
                {"seconds", run_s},
                {"pulses", run.pulses},
                {"frames", run.frames},
                {"complete", run.complete},
                {"degraded", run.degraded},
                {"fps", run.fps},
                {"trigger_to_merged_ms",
                 {{"p50", run.merged.percentile_ms(0.5)}, {"p99", run.merged.percentile_ms(0.99)}}},
                {"rejoin_ms", rejoin_ms},
                {"host_rss_kb", {{"start", rss_start}, {"end", r.host_rss_end_kb}}}};
  }
  return j;
}

}  // namespace vc::bench
