// The renderer. Per camera, once: the viewing ray of every pixel (exact inverse of the OpenCV
// model), the static room image (2x2 supersampled), the distance to the room along every ray,
// and per 16x16 tile the bounds of its rays in normalized image coordinates and of its floor
// points. Per frame: the ~20 body primitives from the pose; per tile, the primitives whose
// projected box overlaps the tile and those whose shadow footprint (box projected from the light
// onto the floor) overlaps its floor; only those tiles are ray cast. A pixel shows the nearest
// primitive hit closer than the room (so the floor hides body parts below it), else the room,
// darkened by shadow_factor where the segment from its floor point to the light touches the body.
// Then flicker (a per-frame gain through a LUT) and noise (a seeded Gaussian table read at a
// per-image offset, added with saturation) over the whole image.
// Limits: hard shadows on the floor only (not on walls or the body), no self-shadowing, no
// inter-reflection, no motion blur, no anti-aliasing of body edges (the truth mask is binary).
#include "voxcap/sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "room.hpp"

namespace vc::sim {
namespace {

constexpr int kTile = 16;
constexpr std::size_t kNoiseSlack = std::size_t{1} << 20;

struct Rect2 {
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  void add(double x, double y) {
    x0 = std::min(x0, x);
    x1 = std::max(x1, x);
    y0 = std::min(y0, y);
    y1 = std::max(y1, y);
  }
  bool empty() const { return x0 > x1; }
  bool overlaps(const Rect2& o) const { return !(o.x0 > x1 || o.x1 < x0 || o.y0 > y1 || o.y1 < y0); }
  static Rect2 everything() { return {-HUGE_VAL, HUGE_VAL, -HUGE_VAL, HUGE_VAL}; }
};

struct TileInfo {
  Rect2 rays;   // normalized image coordinates (x/z, y/z) of its pixels
  Rect2 floor;  // world x, y of its floor pixels (empty when none)
};

struct CameraCache {
  std::once_flag once;
  cv::Vec3d center;
  cv::Matx33d R;
  std::vector<cv::Vec3f> ray;   // unit world direction per pixel
  std::vector<cv::Vec2f> xy;    // its normalized image coordinates (x/z, y/z in the camera)
  std::vector<float> room_t;    // distance to the room surface along the ray
  std::vector<std::uint8_t> is_floor;
  cv::Mat room;                 // CV_8UC3, RGB, clean
  int tiles_x = 0, tiles_y = 0;
  std::vector<TileInfo> tiles;
};

std::uint8_t to_u8(double v) { return cv::saturate_cast<std::uint8_t>(v); }

}  // namespace

struct Scene::Impl {
  SceneOptions opt;
  rig::Calibration calib;
  Motion motion;
  Appearance look;
  detail::Room room;
  cv::Mat noise_pos, noise_neg;  // 1 x L, CV_8U: max(n, 0) and max(-n, 0) of round(sigma * N(0,1))
  std::vector<std::unique_ptr<CameraCache>> cams;

  Impl(const SceneOptions& o, rig::Calibration c, Motion m)
      : opt(o), calib(std::move(c)), motion(std::move(m)), look(appearance_preset(o.appearance)) {}

  CameraCache& cache(int cam) const;
  void build_cache(int cam, CameraCache& cc) const;
  void render_clean(int frame, int cam, cv::Mat& out, cv::Mat* sil, cv::Mat* shadow) const;
  void add_noise(cv::Mat& img, std::uint64_t key, double gain) const;
};

namespace {

std::uint64_t image_key(std::uint64_t seed, std::uint64_t kind, std::uint64_t cam, std::uint64_t index) {
  return detail::mix64(seed ^ detail::mix64(kind * 0x9E3779B97F4A7C15ull ^ detail::mix64(cam * 0xD1B54A32D192ED03ull ^ index)));
}

}  // namespace

bool SceneOptions::valid(std::string* why) const {
  std::ostringstream os;
  std::string w;
  if (!motion.valid(&w)) {
    os << "motion: " << w;
  } else if (!body.valid(&w)) {
    os << "body: " << w;
  } else if (!calibration && !rig.valid(&w)) {
    os << "rig: " << w;
  } else if (calibration && !calibration->valid(&w)) {
    os << "calibration: " << w;
  } else if (!(noise_sigma >= 0 && noise_sigma <= 50)) {
    os << "noise_sigma must be in [0, 50], got " << noise_sigma;
  } else if (!(flicker >= 0 && flicker < 0.5)) {
    os << "flicker must be in [0, 0.5), got " << flicker;
  } else if (!(shadow_factor > 0 && shadow_factor < 1)) {
    os << "shadow_factor must be in (0, 1), got " << shadow_factor;
  } else if (!(room_half_m > 1 && room_half_m < 100) || !(room_height_m > 2 && room_height_m < 100)) {
    os << "room_half_m must be in (1, 100) and room_height_m in (2, 100)";
  } else if (!(light_m[2] > 0.5 && light_m[2] < room_height_m)) {
    os << "the light must hang between 0.5 m and the ceiling";
  } else {
    try {
      (void)appearance_preset(appearance);
    } catch (const std::invalid_argument& e) {
      os << e.what();
      if (why) *why = os.str();
      return false;
    }
    return true;
  }
  if (why) *why = os.str();
  return false;
}

Scene::Scene(const SceneOptions& options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("scene: " + why);
  rig::Calibration calib = options.calibration ? *options.calibration : default_rig(options.rig);
  impl_ = std::make_unique<Impl>(options, std::move(calib), Motion::create(options.motion, options.body));
  Impl& m = *impl_;
  // The room holds every camera (with half a metre to spare).
  double half = options.room_half_m;
  double height = options.room_height_m;
  for (const auto& cam : m.calib.cameras) {
    const cv::Vec3d c = cam.center_world();
    half = std::max({half, std::abs(c[0]) + 0.5, std::abs(c[1]) + 0.5});
    height = std::max(height, c[2] + 0.5);
    if (c[2] <= 0.05) throw std::invalid_argument("scene: camera " + cam.name + " is below the floor");
  }
  m.room.half_m = half;
  m.room.height_m = height;
  m.room.light_m = options.light_m;
  // Noise table: Box-Muller from a counter-based generator, so it is the same everywhere.
  std::size_t max_values = 0;
  for (const auto& cam : m.calib.cameras) {
    max_values = std::max(max_values, static_cast<std::size_t>(cam.width) * static_cast<std::size_t>(cam.height) * 3);
  }
  const std::size_t n = max_values + kNoiseSlack;
  m.noise_pos = cv::Mat::zeros(1, static_cast<int>(n), CV_8U);
  m.noise_neg = cv::Mat::zeros(1, static_cast<int>(n), CV_8U);
  if (options.noise_sigma > 0) {
    auto* pos = m.noise_pos.ptr<std::uint8_t>();
    auto* neg = m.noise_neg.ptr<std::uint8_t>();
    for (std::size_t i = 0; i < n; i += 2) {
      const std::uint64_t h1 = detail::mix64(options.seed ^ (0xA5A5A5A5ull + i));
      const std::uint64_t h2 = detail::mix64(h1 ^ 0x5DEECE66Dull);
      const double u1 = (static_cast<double>(h1 >> 11) + 0.5) * (1.0 / 9007199254740992.0);
      const double u2 = static_cast<double>(h2 >> 11) * (1.0 / 9007199254740992.0);
      const double r = std::sqrt(-2.0 * std::log(u1));
      const double g[2] = {r * std::cos(2 * M_PI * u2), r * std::sin(2 * M_PI * u2)};
      for (std::size_t k = 0; k < 2 && i + k < n; ++k) {
        const long v = std::lround(std::clamp(options.noise_sigma * g[k], -255.0, 255.0));
        pos[i + k] = static_cast<std::uint8_t>(std::max(0L, v));
        neg[i + k] = static_cast<std::uint8_t>(std::max(0L, -v));
      }
    }
  }
  m.cams.resize(m.calib.cameras.size());
  for (auto& c : m.cams) c = std::make_unique<CameraCache>();
}

Scene::~Scene() = default;

const SceneOptions& Scene::options() const { return impl_->opt; }
const rig::Calibration& Scene::calibration() const { return impl_->calib; }
const Motion& Scene::motion() const { return impl_->motion; }
int Scene::camera_count() const { return static_cast<int>(impl_->calib.cameras.size()); }
double Scene::fps() const { return impl_->motion.fps(); }

CameraCache& Scene::Impl::cache(int cam) const {
  if (cam < 0 || cam >= static_cast<int>(cams.size())) throw std::out_of_range("scene: no camera " + std::to_string(cam));
  CameraCache& cc = *cams[static_cast<std::size_t>(cam)];
  std::call_once(cc.once, [&] { build_cache(cam, cc); });
  return cc;
}

void Scene::Impl::build_cache(int cam_index, CameraCache& cc) const {
  const rig::Camera& cam = calib.cameras[static_cast<std::size_t>(cam_index)];
  const int w = cam.width, h = cam.height;
  cc.center = cam.center_world();
  cc.R = cam.R_cam_from_world;
  const cv::Matx33d Rt = cam.R_cam_from_world.t();
  const std::size_t npix = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  cc.ray.resize(npix);
  cc.xy.resize(npix);
  cc.room_t.resize(npix);
  cc.is_floor.resize(npix);
  cc.room.create(h, w, CV_8UC3);
  cc.tiles_x = (w + kTile - 1) / kTile;
  cc.tiles_y = (h + kTile - 1) / kTile;
  cc.tiles.assign(static_cast<std::size_t>(cc.tiles_x * cc.tiles_y), TileInfo{});
  // Undistorted coordinates of every pixel centre (one Newton solve each); the room's 2x2
  // supersamples interpolate between them (the distortion is smooth at this scale).
  std::vector<cv::Vec2d> und(npix);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) und[static_cast<std::size_t>(y * w + x)] = cam.undistort(cv::Point2d(x, y));
  }
  auto und_at = [&](double fx, double fy) {
    // Bilinear (extrapolating at the border) in the grid of pixel centres.
    const int x0 = std::clamp(static_cast<int>(std::floor(fx)), 0, std::max(0, w - 2));
    const int y0 = std::clamp(static_cast<int>(std::floor(fy)), 0, std::max(0, h - 2));
    const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
    const double ax = fx - x0, ay = fy - y0;
    auto U = [&](int xx, int yy) { return und[static_cast<std::size_t>(yy * w + xx)]; };
    return (U(x0, y0) * (1 - ax) + U(x1, y0) * ax) * (1 - ay) + (U(x0, y1) * (1 - ax) + U(x1, y1) * ax) * ay;
  };
  static const double kSub[4][2] = {{-0.25, -0.25}, {0.25, -0.25}, {-0.25, 0.25}, {0.25, 0.25}};
  for (int y = 0; y < h; ++y) {
    auto* row = cc.room.ptr<cv::Vec3b>(y);
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      const cv::Vec2d xy = und[i];
      const cv::Vec3d d = cv::normalize(Rt * cv::Vec3d(xy[0], xy[1], 1.0));
      cc.ray[i] = cv::Vec3f(static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2]));
      cc.xy[i] = cv::Vec2f(static_cast<float>(xy[0]), static_cast<float>(xy[1]));
      // The ray as stored (float) is the one every later test uses.
      const cv::Vec3d df(cc.ray[i][0], cc.ray[i][1], cc.ray[i][2]);
      double t = 0;
      int face = 0;
      if (!room.hit(cc.center, df, &t, &face)) throw std::logic_error("scene: camera outside the room");
      cc.room_t[i] = static_cast<float>(t);
      cc.is_floor[i] = face == detail::kFloor;
      TileInfo& tile = cc.tiles[static_cast<std::size_t>((y / kTile) * cc.tiles_x + x / kTile)];
      tile.rays.add(xy[0], xy[1]);
      if (face == detail::kFloor) {
        const cv::Vec3d p = cc.center + df * static_cast<double>(cc.room_t[i]);
        tile.floor.add(p[0], p[1]);
      }
      cv::Vec3d sum(0, 0, 0);
      for (const auto& s : kSub) {
        const cv::Vec2d sxy = und_at(x + s[0], y + s[1]);
        const cv::Vec3d sd = Rt * cv::Vec3d(sxy[0], sxy[1], 1.0);
        double st = 0;
        int sface = 0;
        if (room.hit(cc.center, sd, &st, &sface)) sum += room.shade(sface, cc.center + sd * st);
      }
      sum *= 0.25;
      row[x] = cv::Vec3b(to_u8(sum[0]), to_u8(sum[1]), to_u8(sum[2]));
    }
  }
}

void Scene::Impl::render_clean(int frame, int cam_index, cv::Mat& out, cv::Mat* sil, cv::Mat* shadow) const {
  if (frame < 0) throw std::out_of_range("scene: negative frame");
  CameraCache& cc = cache(cam_index);
  const rig::Camera& cam = calib.cameras[static_cast<std::size_t>(cam_index)];
  const int w = cam.width, h = cam.height;
  cc.room.copyTo(out);
  // Reuse the caller's buffers (create() keeps them when the size and type already match).
  if (sil) {
    sil->create(h, w, CV_8UC1);
    sil->setTo(0);
  }
  if (shadow) {
    shadow->create(h, w, CV_8UC1);
    shadow->setTo(0);
  }

  std::vector<Primitive> prims;
  build_primitives(motion.body_pose(frame), motion.body(), motion.feet(), &prims);
  const std::size_t np = prims.size();
  std::vector<Rect2> screen(np), footprint(np);
  const cv::Vec3d L = opt.light_m;
  for (std::size_t k = 0; k < np; ++k) {
    for (const cv::Vec3d& c : prims[k].box_corners()) {
      const cv::Vec3d pc = cc.R * (c - cc.center);
      if (pc[2] <= 1e-3) {
        screen[k] = Rect2::everything();
      } else if (screen[k].x1 != HUGE_VAL) {
        screen[k].add(pc[0] / pc[2], pc[1] / pc[2]);
      }
      if (c[2] >= L[2] - 1e-3) {
        footprint[k] = Rect2::everything();
      } else if (footprint[k].x1 != HUGE_VAL) {
        const double s = L[2] / (L[2] - c[2]);
        const cv::Vec3d f = L + (c - L) * s;
        footprint[k].add(f[0], f[1]);
      }
    }
  }
  cv::Vec3d albedo[kPartCount];
  cv::Vec3d eye_local[kPartCount], light_local[kPartCount];
  for (std::size_t k = 0; k < np; ++k) {
    albedo[k] = look.albedo(part_material(prims[k].part));
    eye_local[k] = prims[k].to_local_point(cc.center);
    light_local[k] = prims[k].to_local_point(L);
  }
  const double factor = opt.shadow_factor;
  std::vector<int> body_cand, shadow_cand;
  body_cand.reserve(np);
  shadow_cand.reserve(np);
  for (int ty = 0; ty < cc.tiles_y; ++ty) {
    for (int tx = 0; tx < cc.tiles_x; ++tx) {
      const TileInfo& tile = cc.tiles[static_cast<std::size_t>(ty * cc.tiles_x + tx)];
      body_cand.clear();
      shadow_cand.clear();
      for (std::size_t k = 0; k < np; ++k) {
        if (screen[k].overlaps(tile.rays)) body_cand.push_back(static_cast<int>(k));
        if (opt.shadows && !tile.floor.empty() && footprint[k].overlaps(tile.floor)) shadow_cand.push_back(static_cast<int>(k));
      }
      if (body_cand.empty() && shadow_cand.empty()) continue;
      int last_caster = -1;
      const int y_end = std::min(h, (ty + 1) * kTile), x_end = std::min(w, (tx + 1) * kTile);
      for (int y = ty * kTile; y < y_end; ++y) {
        auto* orow = out.ptr<cv::Vec3b>(y);
        for (int x = tx * kTile; x < x_end; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
          const cv::Vec3d d(cc.ray[i][0], cc.ray[i][1], cc.ray[i][2]);
          const double nx = cc.xy[i][0], ny = cc.xy[i][1];
          double best = cc.room_t[i];
          int hit = -1;
          for (int k : body_cand) {
            const Rect2& r = screen[static_cast<std::size_t>(k)];
            if (nx < r.x0 || nx > r.x1 || ny < r.y0 || ny > r.y1) continue;
            double t;
            if (prims[static_cast<std::size_t>(k)].intersect_from_local(eye_local[k], d, 0.0, &t) && t < best) {
              best = t;
              hit = k;
            }
          }
          if (hit >= 0) {
            const Primitive& p = prims[static_cast<std::size_t>(hit)];
            const cv::Vec3d X = cc.center + d * best;
            const cv::Vec3d n = p.normal(X);
            const double ndl = std::max(0.0, n.dot(cv::normalize(L - X)));
            const cv::Vec3d c = albedo[hit] * (0.40 + 0.62 * ndl + 0.08 * n[2]);
            orow[x] = cv::Vec3b(to_u8(c[0]), to_u8(c[1]), to_u8(c[2]));
            if (sil) sil->at<std::uint8_t>(y, x) = 255;
            continue;
          }
          if (shadow_cand.empty() || !cc.is_floor[i]) continue;
          const cv::Vec3d P = cc.center + d * static_cast<double>(cc.room_t[i]);
          auto casts = [&](int k) {
            const Rect2& r = footprint[static_cast<std::size_t>(k)];
            if (P[0] < r.x0 || P[0] > r.x1 || P[1] < r.y0 || P[1] > r.y1) return false;
            return prims[static_cast<std::size_t>(k)].touches_segment_from_local(light_local[k], P);
          };
          // Neighbouring pixels are usually shadowed by the same part: try it first.
          bool dark = last_caster >= 0 && casts(last_caster);
          for (std::size_t c = 0; !dark && c < shadow_cand.size(); ++c) {
            if (shadow_cand[c] != last_caster && casts(shadow_cand[c])) {
              dark = true;
              last_caster = shadow_cand[c];
            }
          }
          if (!dark) continue;
          cv::Vec3b& px = orow[x];
          px = cv::Vec3b(to_u8(px[0] * factor), to_u8(px[1] * factor), to_u8(px[2] * factor));
          if (shadow) shadow->at<std::uint8_t>(y, x) = 255;
        }
      }
    }
  }
}

void Scene::Impl::add_noise(cv::Mat& img, std::uint64_t key, double gain) const {
  if (gain != 1.0) img.convertTo(img, CV_8U, gain);  // saturate_cast(v * gain)
  if (opt.noise_sigma <= 0) return;
  const int row_values = img.cols * img.channels();
  const int off = static_cast<int>(key % kNoiseSlack);
  if (img.isContinuous()) {
    const int n = row_values * img.rows;
    cv::Mat flat = img.reshape(1, 1);
    cv::add(flat, noise_pos.colRange(off, off + n), flat);
    cv::subtract(flat, noise_neg.colRange(off, off + n), flat);
    return;
  }
  for (int y = 0; y < img.rows; ++y) {  // e.g. a caller's ROI: same values, row by row
    cv::Mat row(1, row_values, CV_8U, img.ptr(y));
    const int o = off + y * row_values;
    cv::add(row, noise_pos.colRange(o, o + row_values), row);
    cv::subtract(row, noise_neg.colRange(o, o + row_values), row);
  }
}

double Scene::flicker_gain(int frame) const {
  if (impl_->opt.flicker <= 0) return 1.0;
  const double u = detail::hash01(frame, 0x46, impl_->opt.seed ^ 0xF11C4E4ull);
  return 1.0 + impl_->opt.flicker * (2 * u - 1);
}

void Scene::render(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth, cv::Mat* shadow_truth) const {
  impl_->render_clean(frame, cam, rgb_out, silhouette_truth, shadow_truth);
  impl_->add_noise(rgb_out, image_key(impl_->opt.seed, 1, static_cast<std::uint64_t>(cam), static_cast<std::uint64_t>(frame)),
                   flicker_gain(frame));
}

void Scene::render_clean(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth, cv::Mat* shadow_truth) const {
  impl_->render_clean(frame, cam, rgb_out, silhouette_truth, shadow_truth);
}

void Scene::render_background(int cam, int i, cv::Mat& rgb_out) const {
  if (i < 0) throw std::out_of_range("scene: negative background index");
  impl_->cache(cam).room.copyTo(rgb_out);
  double gain = 1.0;
  if (impl_->opt.flicker > 0) {
    gain = 1.0 + impl_->opt.flicker * (2 * detail::hash01(i, 0x42, impl_->opt.seed ^ 0xB6C6ull) - 1);
  }
  impl_->add_noise(rgb_out, image_key(impl_->opt.seed, 2, static_cast<std::uint64_t>(cam), static_cast<std::uint64_t>(i)), gain);
}

void Scene::render_background_clean(int cam, cv::Mat& rgb_out) const { impl_->cache(cam).room.copyTo(rgb_out); }

BodyPose Scene::body_pose(int frame) const { return impl_->motion.body_pose(frame); }

std::array<cv::Vec3d, kJointCount> Scene::joints(int frame) const { return body_pose(frame).p_world; }

std::vector<Primitive> Scene::primitives(int frame) const {
  std::vector<Primitive> prims;
  build_primitives(body_pose(frame), impl_->motion.body(), impl_->motion.feet(), &prims);
  return prims;
}

std::vector<FeatureTruth> Scene::features(int frame, int cam_index) const {
  const rig::Camera& cam = impl_->calib.cameras.at(static_cast<std::size_t>(cam_index));
  const BodyPose pose = body_pose(frame);
  const std::vector<Primitive> prims = primitives(frame);
  const cv::Vec3d C = cam.center_world();
  std::vector<FeatureTruth> out;
  for (int f = 0; f < kFeatureCount; ++f) {
    FeatureTruth t;
    t.feature = static_cast<Feature>(f);
    const cv::Vec3d p = pose.p(feature_joint(t.feature));
    t.uv = cam.project(p);
    t.depth_m = cam.to_cam(p)[2];
    t.in_image = t.depth_m > 0 && cam.in_image(t.uv);
    for (const Primitive& prim : prims) {
      if (part_of_feature(prim.part, t.feature)) continue;
      double hit;
      if (prim.intersect(C, p - C, 0.0, &hit) && hit < 1.0) {
        t.occluded = true;
        break;
      }
    }
    t.visible = t.in_image && !t.occluded;
    out.push_back(t);
  }
  return out;
}

bool Scene::occupied(const cv::Vec3d& p_world, int frame) const {
  if (p_world[2] < 0) return false;
  for (const Primitive& prim : primitives(frame)) {
    if (prim.contains(p_world)) return true;
  }
  return false;
}

void Scene::occupancy(const rig::VoxelGrid& grid, int frame, std::vector<std::uint8_t>* bits) const {
  std::string why;
  if (!grid.valid(&why)) throw std::invalid_argument("occupancy: grid: " + why);
  bits->assign(grid.bitset_bytes(), 0);
  for (const Primitive& prim : primitives(frame)) {
    cv::Vec3d lo(HUGE_VAL, HUGE_VAL, HUGE_VAL), hi(-HUGE_VAL, -HUGE_VAL, -HUGE_VAL);
    for (const cv::Vec3d& c : prim.box_corners()) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], c[a]);
        hi[a] = std::max(hi[a], c[a]);
      }
    }
    int i0[3], i1[3];
    const int n[3] = {grid.nx, grid.ny, grid.nz};
    bool empty = false;
    for (int a = 0; a < 3; ++a) {
      // Voxel centres min + (i + 1/2) v inside [lo, hi].
      i0[a] = std::max(0, static_cast<int>(std::ceil((lo[a] - grid.min_m[a]) / grid.voxel_m - 0.5)));
      i1[a] = std::min(n[a] - 1, static_cast<int>(std::floor((hi[a] - grid.min_m[a]) / grid.voxel_m - 0.5)));
      if (i0[a] > i1[a]) empty = true;
    }
    if (empty) continue;
    for (int k = i0[2]; k <= i1[2]; ++k) {
      for (int j = i0[1]; j <= i1[1]; ++j) {
        for (int i = i0[0]; i <= i1[0]; ++i) {
          const cv::Vec3d c = grid.center(i, j, k);
          if (c[2] >= 0 && prim.contains(c)) rig::hull_set(bits->data(), grid.index(i, j, k));
        }
      }
    }
  }
}

}  // namespace vc::sim
