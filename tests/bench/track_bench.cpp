#include "track_bench.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <vector>

#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/track/producer.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::bench {

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(q * double(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

}  // namespace

json run_track_bench(int width, int height, int frames) {
  if (width < 32 || height < 32 || frames < 1) throw std::invalid_argument("track bench: bad size or frames");
  sim::SceneOptions so;
  so.motion.source = "wave";
  so.rig.width = width;
  so.rig.height = height;
  const sim::Scene scene(so);
  constexpr int kCams = 2;  // cameras 0 and 1: the front node's pair
  vc_bgmodel* bgs[kCams] = {nullptr, nullptr};
  std::unique_ptr<vc_bgmodel, void (*)(vc_bgmodel*)> own0(nullptr, vc_bgmodel_free),
      own1(nullptr, vc_bgmodel_free);
  char why[256];
  vc_subtract_params params;
  vc_subtract_params_default(&params);
  for (int c = 0; c < kCams; ++c) {
    if (vc_bgmodel_new(width, height, &bgs[c], why, sizeof(why)) < 0) throw std::runtime_error(why);
    (c == 0 ? own0 : own1).reset(bgs[c]);
    cv::Mat b;
    for (int i = 0; i < 16; ++i) {
      scene.render_background(c, i, b);
      vc_bgmodel_learn(bgs[c], b.data, b.step);
    }
    vc_bgmodel_finish(bgs[c]);
    vc_bgmodel_set_params(bgs[c], &params);
  }
  std::vector<std::uint8_t> scratch(vc_cleanup_radius_scratch_size(width, 1));
  std::vector<std::uint8_t> masks[kCams] = {
      std::vector<std::uint8_t>(std::size_t(width) * std::size_t(height)),
      std::vector<std::uint8_t>(std::size_t(width) * std::size_t(height))};
  track::TrackerOptions topt;
  track::Producer producer(topt);
  const int w[kCams] = {width, width}, h[kCams] = {height, height};
  std::vector<double> t_init, t_track;
  int lost_reports = 0, tracking_reports = 0;
  const int total = topt.init_frames + frames;
  cv::Mat rgb[kCams];
  for (int f = 0; f < total + 1; ++f) {  // the first call warms up and is not counted
    const int frame = std::max(0, f - 1);
    const std::uint8_t* data[kCams];
    std::size_t stride[kCams];
    const std::uint8_t* mask[kCams];
    for (int c = 0; c < kCams; ++c) {
      scene.render(frame, c, rgb[c]);
      vc_subtract(bgs[c], rgb[c].data, rgb[c].step, masks[c].data(), nullptr);
      vc_cleanup_radius(masks[c].data(), width, height, 1, scratch.data(), scratch.size());
      data[c] = rgb[c].data;
      stride[c] = rgb[c].step;
      mask[c] = masks[c].data();
    }
    if (f == 0) producer.reset();
    const bool init = !producer.camera(0).initialised() || !producer.camera(1).initialised();
    vc_features out[kCams];
    const auto t0 = Clock::now();
    if (producer.track(std::uint64_t(f + 1), data, stride, mask, w, h, out) != kCams)
      throw std::runtime_error("track bench: the producer failed");
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / kCams;
    if (f == 0) continue;
    (init ? t_init : t_track).push_back(ms);
    if (init) continue;
    for (const auto& o : out)
      for (int k = 0; k < o.feature_count; ++k) {
        lost_reports += o.features[k].state == VC_FEATURE_LOST;
        tracking_reports += o.features[k].state == VC_FEATURE_TRACKING;
      }
  }
  json j;
  j["motion"] = "wave";
  j["cameras"] = kCams;
  j["init_frames"] = t_init.size();
  j["frames"] = t_track.size();
  j["init_ms_per_camera"] = pct(t_init, 0.5);
  j["frame_ms_per_camera"] = pct(t_track, 0.5);
  j["frame_ms_per_camera_p95"] = pct(t_track, 0.95);
  j["frame_ms_per_camera_max"] = t_track.empty() ? 0.0 : *std::max_element(t_track.begin(), t_track.end());
  j["tracking_share"] =
      (tracking_reports + lost_reports) > 0
          ? double(tracking_reports) / double(std::max<std::size_t>(1, 5 * kCams * t_track.size()))
          : 0.0;
  j["losses"] = producer.camera(0).losses() + producer.camera(1).losses();
  j["reacquisitions"] = producer.camera(0).reacquisitions() + producer.camera(1).reacquisitions();
  j["goal_frame_ms_per_camera_max"] = 0.3;
  j["goal_met"] = pct(t_track, 0.5) <= 0.3;
  return j;
}

}  // namespace vc::bench
