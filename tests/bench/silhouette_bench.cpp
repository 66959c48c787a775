// The offline silhouette evaluator (see silhouette_bench.hpp).
#include "silhouette_bench.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/sim/scene.hpp"
#include "voxcap/subtraction.h"

namespace vc::bench {
namespace {

using vc::sim::Part;

// The body part groups (hw/sim's: head with the neck, torso, each limb segment, a foot with its toes).
const std::array<std::string_view, vc::sim::kPartGroups>& kGroups = vc::sim::part_group_names();
constexpr uint8_t kUnlabelled = 0xFF;

uint8_t group_of(Part p) {
  return static_cast<uint8_t>(vc::sim::part_group(static_cast<int>(p)));
}

bool hand_or_foot(size_t g) {
  const std::string_view n = kGroups[g];
  return n.ends_with("_hand") || n.ends_with("_foot");
}

// Counts of one camera (or of all of them).
struct Counts {
  uint64_t body = 0, body_kept = 0;  // truth-silhouette pixels, of them in the mask
  uint64_t mask = 0;                 // mask pixels (foreground after clean-up)
  uint64_t shadow = 0, shadow_kept = 0;
  uint64_t pixels = 0, band = 0, called_shadow = 0;
  std::array<uint64_t, vc::sim::kPartGroups> part{}, part_kept{};

  void add(const Counts& o) {
    body += o.body;
    body_kept += o.body_kept;
    mask += o.mask;
    shadow += o.shadow;
    shadow_kept += o.shadow_kept;
    pixels += o.pixels;
    band += o.band;
    called_shadow += o.called_shadow;
    for (size_t g = 0; g < part.size(); g++) {
      part[g] += o.part[g];
      part_kept[g] += o.part_kept[g];
    }
  }
};

nlohmann::json ratio(uint64_t num, uint64_t den) {
  return den == 0 ? nlohmann::json(nullptr) : nlohmann::json(static_cast<double>(num) / den);
}

nlohmann::json to_json(const Counts& c) {
  nlohmann::json j;
  j["body_pixels"] = c.body;
  j["recall"] = ratio(c.body_kept, c.body);
  j["precision"] = ratio(c.body_kept, c.mask);
  j["shadow_pixels"] = c.shadow;
  j["shadow_kept"] = ratio(c.shadow_kept, c.shadow);
  j["band_share"] = ratio(c.band, c.pixels);
  j["shadow_share"] = ratio(c.called_shadow, c.pixels);
  uint64_t hf = 0, hf_kept = 0;
  nlohmann::json parts = nlohmann::json::object();
  for (size_t g = 0; g < kGroups.size(); g++) {
    parts[std::string(kGroups[g])] = {{"pixels", c.part[g]}, {"recall", ratio(c.part_kept[g], c.part[g])}};
    if (hand_or_foot(g)) {
      hf += c.part[g];
      hf_kept += c.part_kept[g];
    }
  }
  j["parts"] = parts;
  j["hands_feet_recall"] = ratio(hf_kept, hf);
  return j;
}

// Labels each truth-silhouette pixel with the part group its ray hits first (kUnlabelled where no
// primitive is hit: the renderer and this cast agree to float error on the outline).
void label_parts(const vc::sim::Scene& scene, int frame, int cam, const cv::Mat& sil,
                 std::vector<uint8_t>* out) {
  const vc::rig::Camera& c = scene.calibration().cameras[static_cast<size_t>(cam)];
  const std::vector<vc::sim::Primitive> prims = scene.primitives(frame);
  const cv::Vec3d o = c.center_world();
  std::vector<cv::Vec3d> o_local;
  o_local.reserve(prims.size());
  for (const auto& p : prims) o_local.push_back(p.to_local_point(o));
  out->assign(static_cast<size_t>(sil.rows) * sil.cols, kUnlabelled);
  for (int y = 0; y < sil.rows; y++)
    for (int x = 0; x < sil.cols; x++) {
      if (sil.at<uint8_t>(y, x) == 0) continue;
      const cv::Vec3d d = c.ray_world(cv::Point2d(x, y));
      double best = std::numeric_limits<double>::infinity();
      uint8_t label = kUnlabelled;
      for (size_t i = 0; i < prims.size(); i++) {
        double t = 0;
        if (prims[i].intersect_from_local(o_local[i], d, 0.0, &t) && t < best) {
          best = t;
          label = group_of(prims[i].part);
        }
      }
      (*out)[static_cast<size_t>(y) * sil.cols + x] = label;
    }
}

// The frame dimmed, body kept green, body missed red, other foreground blue (shadow kept: yellow).
cv::Mat overlay(const cv::Mat& rgb, const cv::Mat& sil, const cv::Mat& shadow,
                const std::vector<uint8_t>& mask) {
  cv::Mat bgr(rgb.rows, rgb.cols, CV_8UC3);
  for (int y = 0; y < rgb.rows; y++)
    for (int x = 0; x < rgb.cols; x++) {
      const cv::Vec3b p = rgb.at<cv::Vec3b>(y, x);
      const bool t = sil.at<uint8_t>(y, x) != 0, s = shadow.at<uint8_t>(y, x) != 0;
      const bool m = mask[static_cast<size_t>(y) * rgb.cols + x] != 0;
      cv::Vec3b out(p[2] / 3, p[1] / 3, p[0] / 3);  // BGR for imwrite
      if (t && m) out = cv::Vec3b(0, 200, 0);
      if (t && !m) out = cv::Vec3b(0, 0, 255);
      if (!t && m) out = s ? cv::Vec3b(0, 255, 255) : cv::Vec3b(255, 80, 0);
      bgr.at<cv::Vec3b>(y, x) = out;
    }
  return bgr;
}

struct ModelDeleter {
  void operator()(vc_bgmodel* m) const { vc_bgmodel_free(m); }
};

}  // namespace

bool SilhouetteBenchOptions::valid(std::string* why) const {
  auto fail = [&](std::string s) {
    if (why) *why = std::move(s);
    return false;
  };
  if (frames < 1 || frames > 10000) return fail(fmt::format("--frames: 1..10000, not {}", frames));
  if (every < 1 || every > 10000) return fail(fmt::format("--every: 1..10000, not {}", every));
  if (rig_cameras < 1 || rig_cameras > 64)
    return fail(fmt::format("--rig-cameras: 1..64, not {}", rig_cameras));
  for (int c : cameras)
    if (c < 0 || c >= rig_cameras)
      return fail(fmt::format("--cameras: {} is not a camera of a {}-camera rig", c, rig_cameras));
  if (width < 16 || height < 16 || width > 4096 || height > 4096)
    return fail(fmt::format("--size: 16..4096 each, not {}x{}", width, height));
  if (bg_frames < VC_BACKGROUND_FRAMES_MIN || bg_frames > VC_BACKGROUND_FRAMES_MAX)
    return fail(fmt::format("--bg-frames: {}..{}, not {}", VC_BACKGROUND_FRAMES_MIN, VC_BACKGROUND_FRAMES_MAX,
                            bg_frames));
  return true;
}

nlohmann::json run_silhouette_bench(const SilhouetteBenchOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument(why);
  vc::sim::SceneOptions so;
  so.motion.source = opt.motion;
  so.appearance = opt.appearance;
  so.room = opt.room;
  so.rig.cameras = opt.rig_cameras;
  so.rig.width = opt.width;
  so.rig.height = opt.height;
  const vc::sim::Scene scene(so);  // the emulated rig's noise (sigma 2) and shadows (factor 0.6)
  std::vector<int> cams = opt.cameras;
  if (cams.empty())
    for (int c = 0; c < scene.camera_count(); c++) cams.push_back(c);
  std::vector<int> frames;
  frames.reserve(static_cast<size_t>(opt.frames));
  for (int i = 0; i < opt.frames; i++) frames.push_back(scene.motion().lead_in_frames() + i * opt.every);
  if (!opt.png_dir.empty()) std::filesystem::create_directories(opt.png_dir);

  vc_subtract_params params;
  vc_subtract_params_default(&params);
  if (opt.shadow_texture_k >= 0) params.shadow_texture_k = opt.shadow_texture_k;
  char bad[160];
  if (vc_subtract_params_check(&params, bad, sizeof bad) != 0) throw std::invalid_argument(bad);

  nlohmann::json per_camera = nlohmann::json::array();
  Counts all;
  for (int cam : cams) {
    const auto& c = scene.calibration().cameras[static_cast<size_t>(cam)];
    vc_bgmodel* made = nullptr;
    char reason[160];
    if (vc_bgmodel_new(c.width, c.height, &made, reason, sizeof reason) != 0)
      throw std::runtime_error(reason);
    std::unique_ptr<vc_bgmodel, ModelDeleter> m(made);
    cv::Mat rgb, sil, shadow;
    for (int i = 0; i < opt.bg_frames; i++) {
      scene.render_background(cam, i, rgb);
      if (vc_bgmodel_learn(m.get(), rgb.data, rgb.step) != 0)
        throw std::runtime_error("vc_bgmodel_learn failed");
    }
    if (vc_bgmodel_finish(m.get()) != 0 || vc_bgmodel_set_params(m.get(), &params) != 0)
      throw std::runtime_error("background model: finish/set_params failed");
    const size_t n = static_cast<size_t>(c.width) * c.height;
    std::vector<uint8_t> mask(n), scratch(vc_cleanup_radius_scratch_size(c.width, VC_CLEANUP_RADIUS_PX));
    std::vector<uint8_t> label;
    Counts cc;
    double worst = 2.0;
    cv::Mat worst_png;
    int worst_frame = -1;
    for (int f : frames) {
      scene.render(f, cam, rgb, &sil, &shadow);
      vc_subtract_stats st{};
      if (vc_subtract(m.get(), rgb.data, rgb.step, mask.data(), &st) != 0 ||
          vc_cleanup_radius(mask.data(), c.width, c.height, VC_CLEANUP_RADIUS_PX, scratch.data(),
                            scratch.size()) != 0)
        throw std::runtime_error("vc_subtract/vc_cleanup_radius failed");
      label_parts(scene, f, cam, sil, &label);
      Counts fc;
      fc.pixels = n;
      fc.band = st.band;
      fc.called_shadow = st.shadow;
      for (size_t i = 0; i < n; i++) {
        const bool t = sil.data[i] != 0, e = mask[i] != 0;
        fc.mask += e;
        if (t) {
          fc.body++;
          fc.body_kept += e;
          if (label[i] != kUnlabelled) {
            fc.part[label[i]]++;
            fc.part_kept[label[i]] += e;
          }
        } else if (shadow.data[i] != 0) {
          fc.shadow++;
          fc.shadow_kept += e;
        }
      }
      const double recall = fc.body ? static_cast<double>(fc.body_kept) / fc.body : 1.0;
      if (!opt.png_dir.empty() && recall < worst) {
        worst = recall;
        worst_frame = f;
        worst_png = overlay(rgb, sil, shadow, mask);
      }
      cc.add(fc);
    }
    nlohmann::json j = to_json(cc);
    j["camera"] = cam;
    if (worst_frame >= 0) {
      const std::string path = fmt::format("{}/{}-{}-{}-cam{}-f{}.png", opt.png_dir, opt.motion,
                                           opt.appearance, opt.room, cam, worst_frame);
      cv::imwrite(path, worst_png);
      j["png"] = path;
    }
    per_camera.push_back(std::move(j));
    all.add(cc);
  }
  nlohmann::json out;
  out["motion"] = opt.motion;
  out["appearance"] = opt.appearance;
  out["room"] = opt.room;
  out["width"] = opt.width;
  out["height"] = opt.height;
  out["frames"] = frames;
  out["bg_frames"] = opt.bg_frames;
  out["kernel"] = vc_edge_kernel_name();
  out["cleanup_radius_px"] = VC_CLEANUP_RADIUS_PX;
  out["shadow_texture_k"] = params.shadow_texture_k;
  out["cameras"] = per_camera;
  out["overall"] = to_json(all);
  out["source"] = "edge masks (vc_subtract + vc_cleanup_radius) vs hw/sim truth";
  return out;
}

void print_silhouette_table(const nlohmann::json& j) {
  auto pct = [](const nlohmann::json& v) {
    return v.is_null() ? std::string("   n/a") : fmt::format("{:6.2f}", 100.0 * v.get<double>());
  };
  fmt::print("silhouettes: {} / {} / room {}, {}x{}, {} frames, kernel {} (edge masks vs hw/sim truth, %)\n",
             j["motion"].get<std::string>(), j["appearance"].get<std::string>(), j["room"].get<std::string>(),
             j["width"].get<int>(), j["height"].get<int>(), j["frames"].size(),
             j["kernel"].get<std::string>());
  fmt::print("{:>7} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}\n", "camera", "recall",
             "hnd/ft", "l_hand", "r_hand", "l_foot", "r_foot", "l_farm", "r_farm", "prec", "shadow", "band");
  auto row = [&](const std::string& name, const nlohmann::json& c) {
    const auto& p = c["parts"];
    fmt::print("{:>7} {} {} {} {} {} {} {} {} {} {} {}\n", name, pct(c["recall"]),
               pct(c["hands_feet_recall"]), pct(p["l_hand"]["recall"]), pct(p["r_hand"]["recall"]),
               pct(p["l_foot"]["recall"]), pct(p["r_foot"]["recall"]), pct(p["l_forearm"]["recall"]),
               pct(p["r_forearm"]["recall"]), pct(c["precision"]), pct(c["shadow_kept"]),
               pct(c["band_share"]));
  };
  for (const auto& c : j["cameras"]) row(std::to_string(c["camera"].get<int>()), c);
  row("all", j["overall"]);
  fmt::print("parts (all cameras):");
  for (const auto& [name, v] : j["overall"]["parts"].items()) fmt::print(" {} {}", name, pct(v["recall"]));
  fmt::print("\n");
}

}  // namespace vc::bench
