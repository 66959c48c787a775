// The offline silhouette evaluator (see silhouette_bench.hpp).
#include "silhouette_bench.hpp"

#include <algorithm>
#include <array>
#include <cmath>
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
#include "voxcap/edge/carver.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/rig/c_models.hpp"
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
  uint64_t body_noise = 0;  // body pixels within the background's noise in every channel
  // Where the body pixels the cleaned mask misses went: within the noise (pass A's background),
  // called shadow by the per-pixel tests and the window's (the raw mask's 0 otherwise), or foreground
  // in the raw mask and removed by the clean-up.
  uint64_t lost_noise = 0, lost_shadow = 0, lost_cleanup = 0;
  std::array<uint64_t, vc::sim::kPartGroups> part{}, part_kept{}, part_noise{};
  std::array<uint64_t, vc::sim::kPartGroups> part_lost_shadow{}, part_lost_noise{}, part_lost_cleanup{};

  void add(const Counts& o) {
    body += o.body;
    body_kept += o.body_kept;
    mask += o.mask;
    shadow += o.shadow;
    shadow_kept += o.shadow_kept;
    pixels += o.pixels;
    band += o.band;
    called_shadow += o.called_shadow;
    body_noise += o.body_noise;
    lost_noise += o.lost_noise;
    lost_shadow += o.lost_shadow;
    lost_cleanup += o.lost_cleanup;
    for (size_t g = 0; g < part.size(); g++) {
      part_lost_shadow[g] += o.part_lost_shadow[g];
      part_lost_noise[g] += o.part_lost_noise[g];
      part_lost_cleanup[g] += o.part_lost_cleanup[g];
      part[g] += o.part[g];
      part_kept[g] += o.part_kept[g];
      part_noise[g] += o.part_noise[g];
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
  j["within_noise"] = ratio(c.body_noise, c.body);
  j["lost"] = {{"within_noise", ratio(c.lost_noise, c.body)},
               {"called_shadow", ratio(c.lost_shadow, c.body)},
               {"cleanup", ratio(c.lost_cleanup, c.body)}};
  uint64_t hf = 0, hf_kept = 0;
  nlohmann::json parts = nlohmann::json::object();
  for (size_t g = 0; g < kGroups.size(); g++) {
    parts[std::string(kGroups[g])] = {{"pixels", c.part[g]},
                                      {"recall", ratio(c.part_kept[g], c.part[g])},
                                      {"within_noise", ratio(c.part_noise[g], c.part[g])},
                                      {"lost_called_shadow", ratio(c.part_lost_shadow[g], c.part[g])},
                                      {"lost_within_noise", ratio(c.part_lost_noise[g], c.part[g])},
                                      {"lost_cleanup", ratio(c.part_lost_cleanup[g], c.part[g])}};
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

// Whether pixel p is within the background's noise in every channel: |p - mu| <= ceil(T_l sigma) - 1
// (sigma floored), eq. 1's background as vc_bgmodel_set_params computes it. No subtraction of this
// model can keep such a body pixel (the clean-up may fill it in).
bool within_noise(const uint8_t* p, const uint8_t* mu, const uint16_t* sigma_q8,
                  const vc_subtract_params& params) {
  for (int c = 0; c < 3; c++) {
    const double tl = std::ceil(params.t_lower * std::max(sigma_q8[c] / 256.0, params.sigma_floor)) - 1.0;
    if (std::abs(static_cast<double>(p[c]) - mu[c]) > tl) return false;
  }
  return true;
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

// "centre", "footprint", "subpixel" -> the rule; -1 for another name.
int carve_rule(const std::string& name) {
  if (name == "centre") return VC_CARVE_CENTRE;
  if (name == "footprint") return VC_CARVE_FOOTPRINT;
  if (name == "subpixel") return VC_CARVE_SUBPIXEL;
  return -1;
}

// The merged hull of a rig of nodes (cameras 2k and 2k + 1 on node k) from the edges' masks, against
// hw/sim's true occupancy: the grid is the emulated rig's (grid^3 over [-1.12, 1.12]^2 x [0, 2.24] m),
// each node carves with the edge's carver and the hulls are ANDed (the host's merge, on bitsets).
class HullScorer {
 public:
  HullScorer(const vc::sim::Scene& scene, const SilhouetteBenchOptions& opt) : scene_(scene), opt_(opt) {
    grid_.min_m = cv::Vec3d(-1.12, -1.12, 0.0);
    grid_.voxel_m = 2.24 / opt.grid;
    grid_.nx = grid_.ny = grid_.nz = opt.grid;
    const vc_voxel_grid g = vc::rig::to_c_grid(grid_);
    const auto& cal = scene.calibration();
    for (int k = 0; k < opt.nodes; k++) {
      const vc_camera a = vc::rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k)]);
      const vc_camera b = vc::rig::to_c_camera(cal.cameras[2 * static_cast<size_t>(k) + 1]);
      vc_carver* c = nullptr;
      char why[200];
      if (vc_carver_new(&g, &a, &b, static_cast<vc_carve_rule>(carve_rule(opt.carve)), &c, why, sizeof why) <
          0)
        throw std::runtime_error(std::string("cannot build a carver for the rig: ") + why);
      carvers_.emplace_back(c);
    }
    const size_t bytes = vc_carver_bitset_bytes(carvers_.front().get());
    merged_.resize(bytes);
    part_.resize(bytes);
  }

  // masks: the cleaned mask of every camera of the rig, in rig order.
  void score(int frame, const std::vector<const uint8_t*>& masks) {
    std::fill(merged_.begin(), merged_.end(), 0xFF);
    for (size_t k = 0; k < carvers_.size(); k++) {
      if (vc_carver_run(carvers_[k].get(), masks[2 * k], masks[2 * k + 1], part_.data(), nullptr) != 0)
        throw std::runtime_error("vc_carver_run failed");
      for (size_t i = 0; i < merged_.size(); i++) merged_[i] &= part_[i];
    }
    scene_.occupancy_parts(grid_, frame, &label_);
    const int n[3] = {grid_.nx, grid_.ny, grid_.nz};
    auto in_hull = [&](size_t v) { return ((merged_[v / 8] >> (v % 8)) & 1u) != 0; };
    auto body = [&](int i, int j, int k) {
      return i >= 0 && j >= 0 && k >= 0 && i < n[0] && j < n[1] && k < n[2] &&
             label_[grid_.index(i, j, k)] != vc::sim::Scene::kNoPart;
    };
    uint64_t hull_n = 0, near = 0;
    for (int k = 0; k < n[2]; k++)
      for (int j = 0; j < n[1]; j++)
        for (int i = 0; i < n[0]; i++) {
          const size_t v = grid_.index(i, j, k);
          const uint8_t lab = label_[v];
          if (lab != vc::sim::Scene::kNoPart) {
            const size_t g = group_of(static_cast<Part>(lab));
            part_n_[g]++;
            part_in_[g] += in_hull(v);
            if (!in_hull(v)) {  // which cameras' masks carved it away (a camera that sees it empty)
              const int missed = count_misses(masks, i, j, k);
              part_lost_one_[g] += missed == 1;
            }
          }
          if (!in_hull(v)) continue;
          hull_n++;
          bool close = false;  // a body voxel in the 3x3x3 neighbourhood
          for (int dk = -1; dk <= 1 && !close; dk++)
            for (int dj = -1; dj <= 1 && !close; dj++)
              for (int di = -1; di <= 1 && !close; di++) close = body(i + di, j + dj, k + dk);
          near += close;
        }
    hull_voxels_ += hull_n;
    hull_near_ += near;
    frames_++;
  }

  // The cameras whose mask has no foreground in the pixels voxel (i, j, k) reads (a node that does
  // not see the voxel counts its two cameras), each counted in cam_miss_.
  int count_misses(const std::vector<const uint8_t*>& masks, int i, int j, int k) {
    int missed = 0;
    for (size_t n = 0; n < carvers_.size(); n++) {
      uint32_t rect[2][4];
      if (vc_carver_footprint(carvers_[n].get(), static_cast<uint32_t>(i), static_cast<uint32_t>(j),
                              static_cast<uint32_t>(k), rect) != 1) {
        missed += 2;
        continue;
      }
      for (size_t c = 0; c < 2; c++) {
        const uint8_t* m = masks[2 * n + c];
        bool fg = false;
        for (uint32_t y = rect[c][1]; y <= rect[c][3] && !fg; y++)
          for (uint32_t x = rect[c][0]; x <= rect[c][2] && !fg; x++)
            fg = m[static_cast<size_t>(y) * static_cast<size_t>(opt_.width) + x] != 0;
        if (!fg) {
          missed++;
          cam_miss_[2 * n + c]++;
        }
      }
    }
    return missed;
  }

  nlohmann::json json() const {
    nlohmann::json j;
    j["nodes"] = opt_.nodes;
    j["grid"] = opt_.grid;
    j["carve"] = opt_.carve;
    j["frames"] = frames_;
    uint64_t all = 0, in = 0;
    nlohmann::json parts = nlohmann::json::object();
    double worst_hf = 2.0;
    std::string worst_name;
    for (size_t g = 0; g < kGroups.size(); g++) {
      all += part_n_[g];
      in += part_in_[g];
      parts[std::string(kGroups[g])] = {{"voxels", part_n_[g]},
                                        {"recall", ratio(part_in_[g], part_n_[g])},
                                        {"lost_by_one_camera", ratio(part_lost_one_[g], part_n_[g])}};
      if (hand_or_foot(g) && part_n_[g] > 0) {
        const double r = static_cast<double>(part_in_[g]) / static_cast<double>(part_n_[g]);
        if (r < worst_hf) worst_hf = r, worst_name = kGroups[g];
      }
    }
    j["body_voxels"] = all;
    j["recall"] = ratio(in, all);
    j["parts"] = parts;
    j["worst_hand_foot"] = worst_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(worst_name);
    j["worst_hand_foot_recall"] = worst_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(worst_hf);
    j["lost_by_camera"] = cam_miss_;  // body voxels out of the hull that each camera's mask misses
    j["hull_voxels"] = hull_voxels_;
    j["precision"] = ratio(hull_near_, hull_voxels_);
    return j;
  }

 private:
  struct CarverDeleter {
    void operator()(vc_carver* c) const { vc_carver_free(c); }
  };
  const vc::sim::Scene& scene_;
  const SilhouetteBenchOptions& opt_;
  vc::rig::VoxelGrid grid_;
  std::vector<std::unique_ptr<vc_carver, CarverDeleter>> carvers_;
  std::vector<uint8_t> merged_, part_, label_;
  std::array<uint64_t, vc::sim::kPartGroups> part_n_{}, part_in_{}, part_lost_one_{};
  std::vector<uint64_t> cam_miss_ = std::vector<uint64_t>(2 * static_cast<size_t>(opt_.nodes), 0);
  uint64_t hull_voxels_ = 0, hull_near_ = 0, frames_ = 0;
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
  if (nodes < 0 || nodes > 32) return fail(fmt::format("--nodes: 0..32, not {}", nodes));
  if (nodes > 0 && !cameras.empty()) return fail("--nodes: every camera of the rig is used; no --cameras");
  const int ncam = nodes > 0 ? 2 * nodes : rig_cameras;
  for (int c : cameras)
    if (c < 0 || c >= ncam)
      return fail(fmt::format("--cameras: {} is not a camera of a {}-camera rig", c, ncam));
  if (width < 16 || height < 16 || width > 4096 || height > 4096)
    return fail(fmt::format("--size: 16..4096 each, not {}x{}", width, height));
  if (bg_frames < VC_BACKGROUND_FRAMES_MIN || bg_frames > VC_BACKGROUND_FRAMES_MAX)
    return fail(fmt::format("--bg-frames: {}..{}, not {}", VC_BACKGROUND_FRAMES_MIN, VC_BACKGROUND_FRAMES_MAX,
                            bg_frames));
  if (grid < 8 || grid > 512) return fail(fmt::format("--grid: 8..512, not {}", grid));
  if (carve_rule(carve) < 0)
    return fail(fmt::format("--carve: centre, footprint or subpixel, not '{}'", carve));
  return true;
}

nlohmann::json run_silhouette_bench(const SilhouetteBenchOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument(why);
  vc::sim::SceneOptions so;
  so.motion.source = opt.motion;
  so.appearance = opt.appearance;
  so.room = opt.room;
  so.rig.cameras = opt.nodes > 0 ? 2 * opt.nodes : opt.rig_cameras;
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
  if (opt.shadow_flat_margin >= 0) params.shadow_flat_margin = opt.shadow_flat_margin;
  if (opt.grow_px >= 0) params.grow_px = opt.grow_px;
  if (opt.grow_sigma > 0) params.grow_sigma = opt.grow_sigma;
  if (opt.grow_flat >= 0) params.grow_flat = opt.grow_flat;
  char bad[160];
  if (vc_subtract_params_check(&params, bad, sizeof bad) != 0) throw std::invalid_argument(bad);

  // One background model, mask and score per camera; the frames outer, so a frame's masks are at
  // hand together for the hull.
  struct Camera {
    int index = 0, width = 0, height = 0;
    std::unique_ptr<vc_bgmodel, ModelDeleter> model;
    std::vector<uint8_t> mask;
    Counts counts;
    double worst = 2.0;
    cv::Mat worst_png;
    int worst_frame = -1;
  };
  std::vector<Camera> cam_state(cams.size());
  cv::Mat rgb, sil, shadow;
  size_t scratch_bytes = 0;
  for (size_t ci = 0; ci < cams.size(); ci++) {
    Camera& s = cam_state[ci];
    const auto& c = scene.calibration().cameras[static_cast<size_t>(cams[ci])];
    s.index = cams[ci];
    s.width = c.width;
    s.height = c.height;
    vc_bgmodel* made = nullptr;
    char reason[160];
    if (vc_bgmodel_new(c.width, c.height, &made, reason, sizeof reason) != 0)
      throw std::runtime_error(reason);
    s.model.reset(made);
    for (int i = 0; i < opt.bg_frames; i++) {
      scene.render_background(s.index, i, rgb);
      if (vc_bgmodel_learn(s.model.get(), rgb.data, rgb.step) != 0)
        throw std::runtime_error("vc_bgmodel_learn failed");
    }
    if (vc_bgmodel_finish(s.model.get()) != 0 || vc_bgmodel_set_params(s.model.get(), &params) != 0)
      throw std::runtime_error("background model: finish/set_params failed");
    s.mask.resize(static_cast<size_t>(c.width) * c.height);
    scratch_bytes = std::max(scratch_bytes, vc_cleanup_radius_scratch_size(c.width, VC_CLEANUP_RADIUS_PX));
  }
  std::vector<uint8_t> scratch(scratch_bytes), label, raw;
  std::unique_ptr<HullScorer> hull;
  if (opt.nodes > 0) hull = std::make_unique<HullScorer>(scene, opt);

  for (int f : frames) {
    for (Camera& s : cam_state) {
      scene.render(f, s.index, rgb, &sil, &shadow);
      vc_subtract_stats st{};
      if (vc_subtract(s.model.get(), rgb.data, rgb.step, s.mask.data(), &st) != 0)
        throw std::runtime_error("vc_subtract failed");
      raw = s.mask;        // before the clean-up, for the lost pixels' causes
      uint32_t grown = 0;  // vc_mask_frame's second half: the clean-up, then the limb-scale cue
      if (vc_cleanup_grow(s.model.get(), rgb.data, rgb.step, s.mask.data(), VC_CLEANUP_RADIUS_PX,
                          scratch.data(), scratch.size(), &grown) != 0)
        throw std::runtime_error("vc_cleanup_grow failed");
      st.grown = grown;
      label_parts(scene, f, s.index, sil, &label);
      Counts fc;
      const size_t n = s.mask.size();
      if (!rgb.isContinuous()) throw std::runtime_error("hw/sim rendered a non-continuous frame");
      const uint8_t* mean = vc_bgmodel_mean(s.model.get());
      const uint16_t* sigma = vc_bgmodel_sigma_q8(s.model.get());
      fc.pixels = n;
      fc.band = st.band;
      fc.called_shadow = st.shadow;
      for (size_t i = 0; i < n; i++) {
        const bool t = sil.data[i] != 0, e = s.mask[i] != 0;
        fc.mask += e;
        if (t) {
          fc.body++;
          fc.body_kept += e;
          const bool noise = within_noise(rgb.data + 3 * i, mean + 3 * i, sigma + 3 * i, params);
          fc.body_noise += noise;
          const bool called_shadow = !e && !noise && raw[i] == 0;
          if (!e) {
            fc.lost_noise += noise;
            fc.lost_shadow += called_shadow;
            fc.lost_cleanup += raw[i] != 0;
          }
          if (label[i] != kUnlabelled) {
            fc.part_lost_shadow[label[i]] += called_shadow;
            fc.part_lost_noise[label[i]] += !e && noise;
            fc.part_lost_cleanup[label[i]] += !e && raw[i] != 0;
            fc.part[label[i]]++;
            fc.part_kept[label[i]] += e;
            fc.part_noise[label[i]] += noise;
          }
        } else if (shadow.data[i] != 0) {
          fc.shadow++;
          fc.shadow_kept += e;
        }
      }
      const double recall = fc.body ? static_cast<double>(fc.body_kept) / fc.body : 1.0;
      if (!opt.png_dir.empty() && recall < s.worst) {
        s.worst = recall;
        s.worst_frame = f;
        s.worst_png = overlay(rgb, sil, shadow, s.mask);
      }
      s.counts.add(fc);
    }
    if (hull) {
      std::vector<const uint8_t*> masks;
      masks.reserve(cam_state.size());
      for (const Camera& s : cam_state) masks.push_back(s.mask.data());
      hull->score(f, masks);
    }
  }

  nlohmann::json per_camera = nlohmann::json::array();
  Counts all;
  for (Camera& s : cam_state) {
    nlohmann::json j = to_json(s.counts);
    j["camera"] = s.index;
    if (s.worst_frame >= 0) {
      const std::string path = fmt::format("{}/{}-{}-{}-cam{}-f{}.png", opt.png_dir, opt.motion,
                                           opt.appearance, opt.room, s.index, s.worst_frame);
      cv::imwrite(path, s.worst_png);
      j["png"] = path;
    }
    per_camera.push_back(std::move(j));
    all.add(s.counts);
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
  out["shadow_flat_margin"] = params.shadow_flat_margin;
  out["grow_px"] = params.grow_px;
  out["grow_sigma"] = params.grow_sigma;
  out["grow_flat"] = params.grow_flat;
  out["cameras"] = per_camera;
  out["overall"] = to_json(all);
  if (hull) out["hull"] = hull->json();
  out["source"] = "edge masks (vc_subtract + vc_cleanup_grow: clean-up and limb-scale cue) vs hw/sim truth";
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
  fmt::print(
      "body pixels within the background's noise (no subtraction keeps them): {} (hands {} {}, feet {} {})\n",
      pct(j["overall"]["within_noise"]), pct(j["overall"]["parts"]["l_hand"]["within_noise"]),
      pct(j["overall"]["parts"]["r_hand"]["within_noise"]),
      pct(j["overall"]["parts"]["l_foot"]["within_noise"]),
      pct(j["overall"]["parts"]["r_foot"]["within_noise"]));
  if (!j.contains("hull")) return;
  const auto& h = j["hull"];
  fmt::print(
      "merged hull ({} nodes, {}^3, {} carve, {} frames, edge masks vs true occupancy, %): recall {}, "
      "precision {}, worst hand/foot {} {}\n",
      h["nodes"].get<int>(), h["grid"].get<int>(), h["carve"].get<std::string>(), h["frames"].get<int>(),
      pct(h["recall"]), pct(h["precision"]),
      h["worst_hand_foot"].is_null() ? std::string("-") : h["worst_hand_foot"].get<std::string>(),
      pct(h["worst_hand_foot_recall"]));
  fmt::print("hull parts:");
  for (const auto& [name, v] : h["parts"].items()) fmt::print(" {} {}", name, pct(v["recall"]));
  fmt::print("\n");
}

}  // namespace vc::bench
