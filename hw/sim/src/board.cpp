// The calibration board sequence. Rendering is inverse mapping: every pixel of the board's projected
// bounding box is sampled 4×4 times; each sample's undistorted viewing ray (from a per-camera map of the
// pixel centres' undistorted coordinates and its local Jacobian, so the lens distortion is exact to far
// below a pixel) meets the board plane through the inverse of the plane's homography, and the printed
// texture is read bilinearly there. Samples off the board keep the room. The samples' mean is the
// pixel, so board edges and corners are anti-aliased as a real sensor integrates them; then noise.
// Limits: no blur, no shadow of the board, no occlusion by the person holding it.
#include "voxcap/sim/board.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <utility>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/rig/aruco_dictionary.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kSquarePx = 64;  // texture pixels per square
constexpr int kSub = 4;        // samples per pixel side
constexpr double kPaper = 232, kInk = 28, kCardBack = 120;

cv::Vec3d unit(const cv::Vec3d& v) {
  return v / cv::norm(v);
}

}  // namespace

bool CharucoSpec::valid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (squares_x < 2 || squares_y < 2 || squares_x > 64 || squares_y > 64)
    return fail("board squares must be 2..64");
  if (!(square_m > 0.005 && square_m < 1.0)) return fail("board square_m must be in (0.005, 1) m");
  if (!(marker_m > 0 && marker_m < square_m)) return fail("board marker_m must be in (0, square_m)");
  if (!(margin_m >= 0 && margin_m < 1.0)) return fail("board margin_m must be in [0, 1) m");
  try {
    (void)cv::aruco::getPredefinedDictionary(rig::aruco_dictionary_id(dictionary));
  } catch (const std::invalid_argument& e) {
    return fail(e.what());
  }
  return true;
}

bool BoardCaptureOptions::valid(std::string* why) const {
  if (!board.valid(why)) return false;
  if (held_poses < 1 || held_poses > 10000) {
    if (why) *why = "held_poses must be 1..10000";
    return false;
  }
  if (!(noise_sigma >= 0 && noise_sigma <= 64)) {
    if (why) *why = "noise_sigma must be in [0, 64]";
    return false;
  }
  if (calibration) return calibration->valid(why);
  return rig.valid(why);
}

struct BoardScene::Impl {
  BoardCaptureOptions opt;
  rig::Calibration calib;
  std::unique_ptr<Scene> room;  // the empty room behind the board
  cv::Mat texture;              // CV_8UC1
  double px_per_m = 0;
  std::vector<cv::Vec3d> corners;
  std::vector<cv::Matx33d> R;
  std::vector<cv::Vec3d> t;
  // Per camera, lazily: the undistorted normalized coordinates of every pixel centre (CV_64FC2).
  mutable std::vector<std::once_flag> map_once;
  mutable std::vector<cv::Mat> undist;

  const cv::Mat& undistort_map(int cam) const {
    std::call_once(map_once[static_cast<std::size_t>(cam)], [&] {
      const rig::Camera& c = calib.cameras[static_cast<std::size_t>(cam)];
      cv::Mat m(c.height, c.width, CV_64FC2);
      for (int v = 0; v < c.height; ++v) {
        auto* row = m.ptr<cv::Vec2d>(v);
        for (int u = 0; u < c.width; ++u) row[u] = c.undistort(cv::Point2d(u, v));
      }
      undist[static_cast<std::size_t>(cam)] = m;
    });
    return undist[static_cast<std::size_t>(cam)];
  }
};

BoardScene::BoardScene(const BoardCaptureOptions& options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("board capture: " + why);
  Impl& I = *impl_;
  I.opt = options;
  I.calib = options.calibration ? *options.calibration : default_rig(options.rig);
  const std::size_t n_cam = I.calib.cameras.size();
  I.map_once = std::vector<std::once_flag>(n_cam);
  I.undist.resize(n_cam);

  SceneOptions so;
  so.calibration = I.calib;
  so.room = options.room;
  so.noise_sigma = 0;
  so.seed = options.seed;
  I.room = std::make_unique<Scene>(so);

  const CharucoSpec& b = options.board;
  auto board = cv::aruco::CharucoBoard::create(
      b.squares_x, b.squares_y, static_cast<float>(b.square_m), static_cast<float>(b.marker_m),
      cv::aruco::getPredefinedDictionary(rig::aruco_dictionary_id(b.dictionary)));
  I.px_per_m = kSquarePx / b.square_m;
  const int margin_px = static_cast<int>(std::lround(b.margin_m * I.px_per_m));
  I.opt.board.margin_m = margin_px / I.px_per_m;  // what is printed
  board->draw(cv::Size(b.squares_x * kSquarePx + 2 * margin_px, b.squares_y * kSquarePx + 2 * margin_px),
              I.texture, margin_px, 1);
  // The chessboard corners are exact multiples of the square in the texture: they are what is measured.
  for (const cv::Point3f& p : board->chessboardCorners) {
    I.corners.emplace_back(static_cast<double>(p.x), static_cast<double>(p.y), 0.0);
  }

  // Held poses: the printed face turned towards directions spread evenly round the ring (with jitter), a
  // little down or more up, rolled in its plane, the centre anywhere in the volume (so it reaches the images'
  // edges).
  cv::RNG rng(options.seed * 0x9E3779B97F4A7C15ull + 0xB0A2Dull);
  const RigLayout& L = options.rig;
  const cv::Vec3d lo =
      options.calibration && options.calibration->grid ? options.calibration->grid->min_m : L.volume_min_m;
  const cv::Vec3d hi =
      options.calibration && options.calibration->grid ? options.calibration->grid->max_m() : L.volume_max_m;
  const double w_m = b.squares_x * b.square_m, h_m = b.squares_y * b.square_m;
  const int n = options.held_poses;
  for (int i = 0; i < n; ++i) {
    const double yaw = 2 * kPi * (i + rng.uniform(0.0, 1.0)) / n;
    const double el = rng.uniform(-20.0, 50.0) * kPi / 180;
    const cv::Vec3d face{std::cos(yaw) * std::cos(el), std::sin(yaw) * std::cos(el), std::sin(el)};
    const cv::Vec3d z_b = -face;
    cv::Vec3d x_b = unit(z_b.cross(cv::Vec3d(0, 0, 1)));
    cv::Vec3d y_b = z_b.cross(x_b);
    const double roll = rng.uniform(-35.0, 35.0) * kPi / 180;
    const cv::Vec3d xr = std::cos(roll) * x_b + std::sin(roll) * y_b;
    const cv::Vec3d yr = z_b.cross(xr);
    const cv::Matx33d R(xr[0], yr[0], z_b[0], xr[1], yr[1], z_b[1], xr[2], yr[2], z_b[2]);
    const cv::Vec3d span = hi - lo;
    const cv::Vec3d c{lo[0] + span[0] * rng.uniform(0.05, 0.95), lo[1] + span[1] * rng.uniform(0.05, 0.95),
                      lo[2] + span[2] * rng.uniform(0.06, 0.9)};
    I.R.push_back(R);
    I.t.push_back(c - R * cv::Vec3d(w_m / 2, h_m / 2, 0));
  }
  I.R.emplace_back(1, 0, 0, 0, -1, 0, 0, 0, -1);
  I.t.push_back(options.floor_origin_m);
}

BoardScene::~BoardScene() = default;

const BoardCaptureOptions& BoardScene::options() const {
  return impl_->opt;
}
const rig::Calibration& BoardScene::calibration() const {
  return impl_->calib;
}
int BoardScene::camera_count() const {
  return static_cast<int>(impl_->calib.cameras.size());
}
int BoardScene::frame_count() const {
  return static_cast<int>(impl_->R.size());
}
int BoardScene::floor_frame() const {
  return frame_count() - 1;
}
const std::vector<cv::Vec3d>& BoardScene::corners_board() const {
  return impl_->corners;
}
const cv::Mat& BoardScene::texture() const {
  return impl_->texture;
}
double BoardScene::texture_px_per_m() const {
  return impl_->px_per_m;
}

cv::Matx33d BoardScene::R_world_from_board(int frame) const {
  if (frame < 0 || frame >= frame_count()) throw std::out_of_range("board scene: frame out of range");
  return impl_->R[static_cast<std::size_t>(frame)];
}
cv::Vec3d BoardScene::t_world_from_board(int frame) const {
  if (frame < 0 || frame >= frame_count()) throw std::out_of_range("board scene: frame out of range");
  return impl_->t[static_cast<std::size_t>(frame)];
}

void BoardScene::render(int frame, int cam, cv::Mat& rgb_out) const {
  const Impl& I = *impl_;
  if (cam < 0 || cam >= camera_count()) throw std::out_of_range("board scene: camera out of range");
  const rig::Camera& c = I.calib.cameras[static_cast<std::size_t>(cam)];
  I.room->render_background_clean(cam, rgb_out);

  // Board -> camera.
  const cv::Matx33d R = c.R_cam_from_world * R_world_from_board(frame);
  const cv::Vec3d t = c.R_cam_from_world * t_world_from_board(frame) + c.t_cam_from_world;
  const double m = I.opt.board.margin_m;
  const double w_m = I.opt.board.squares_x * I.opt.board.square_m + m;
  const double h_m = I.opt.board.squares_y * I.opt.board.square_m + m;
  // The board's outline, sampled along its edges (distortion bends them), gives the pixels to visit.
  double u0 = 1e30, v0 = 1e30, u1 = -1e30, v1 = -1e30;
  bool in_front = true;
  for (int e = 0; e <= 32 && in_front; ++e) {
    const double s = e / 32.0;
    const std::array<cv::Vec3d, 4> pts{
        cv::Vec3d(-m + s * (w_m + m), -m, 0), cv::Vec3d(-m + s * (w_m + m), h_m, 0),
        cv::Vec3d(-m, -m + s * (h_m + m), 0), cv::Vec3d(w_m, -m + s * (h_m + m), 0)};
    for (const cv::Vec3d& p : pts) {
      const cv::Vec3d pc = R * p + t;
      if (pc[2] < 0.05) {
        in_front = false;
        break;
      }
      const cv::Vec2d xy = c.distort(cv::Vec2d(pc[0] / pc[2], pc[1] / pc[2]));
      const double u = c.K(0, 0) * xy[0] + c.K(0, 2), v = c.K(1, 1) * xy[1] + c.K(1, 2);
      u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
  }
  if (in_front && u1 >= -1 && v1 >= -1 && u0 <= c.width && v0 <= c.height) {
    const int iu0 = std::max(0, static_cast<int>(std::floor(u0)) - 1);
    const int iv0 = std::max(0, static_cast<int>(std::floor(v0)) - 1);
    const int iu1 = std::min(c.width - 1, static_cast<int>(std::ceil(u1)) + 1);
    const int iv1 = std::min(c.height - 1, static_cast<int>(std::ceil(v1)) + 1);
    const cv::Matx33d H(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
    const cv::Matx33d Hinv = H.inv();
    // The printed face looks at the camera when its normal (-z_board) points to it: r3 · t > 0.
    const bool front = R(0, 2) * t[0] + R(1, 2) * t[1] + R(2, 2) * t[2] > 0;
    // Lambert shading of the board by the room's light, from its centre.
    const cv::Vec3d centre_w =
        R_world_from_board(frame) * cv::Vec3d(w_m / 2, h_m / 2, 0) + t_world_from_board(frame);
    const cv::Vec3d to_light = unit(cv::Vec3d(1.2, 0.9, 2.9) - centre_w);
    const cv::Vec3d normal_w = R_world_from_board(frame) * cv::Vec3d(0, 0, 1);
    const double shade = 0.55 + 0.45 * std::abs(normal_w.dot(to_light));
    const cv::Mat& map = I.undistort_map(cam);
    const cv::Mat& tex = I.texture;
    const double ppm = I.px_per_m;
    for (int v = iv0; v <= iv1; ++v) {
      auto* out = rgb_out.ptr<cv::Vec3b>(v);
      const auto* mrow = map.ptr<cv::Vec2d>(v);
      const auto* mnext = map.ptr<cv::Vec2d>(v + 1 < c.height ? v + 1 : v - 1);
      for (int u = iu0; u <= iu1; ++u) {
        const cv::Vec2d p = mrow[u];
        const cv::Vec2d du = (u + 1 < c.width ? mrow[u + 1] - p : p - mrow[u - 1]);
        const cv::Vec2d dv = (v + 1 < c.height ? mnext[u] - p : p - mnext[u]);
        double sum = 0;
        int covered = 0;
        for (int sy = 0; sy < kSub; ++sy) {
          for (int sx = 0; sx < kSub; ++sx) {
            const double ou = (sx + 0.5) / kSub - 0.5, ov = (sy + 0.5) / kSub - 0.5;
            const cv::Vec2d xy = p + ou * du + ov * dv;
            const cv::Vec3d bw = Hinv * cv::Vec3d(xy[0], xy[1], 1.0);
            if (bw[2] <= 0) continue;  // behind the camera
            const double X = bw[0] / bw[2], Y = bw[1] / bw[2];
            if (X < -m || X > w_m || Y < -m || Y > h_m) continue;
            ++covered;
            if (!front) {
              sum += kCardBack;
              continue;
            }
            const double tu = std::clamp((X + m) * ppm - 0.5, 0.0, tex.cols - 1.0);
            const double tv = std::clamp((Y + m) * ppm - 0.5, 0.0, tex.rows - 1.0);
            const int x0 = std::min(static_cast<int>(tu), tex.cols - 2),
                      y0 = std::min(static_cast<int>(tv), tex.rows - 2);
            const double fx = tu - x0, fy = tv - y0;
            const uchar* r0 = tex.ptr<uchar>(y0);
            const uchar* r1 = tex.ptr<uchar>(y0 + 1);
            const double a =
                (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
            sum += kInk + (kPaper - kInk) * a / 255.0;
          }
        }
        if (covered == 0) continue;
        const double n_s = kSub * kSub;
        const double board_part = shade * sum / n_s, keep = 1.0 - covered / n_s;
        for (int ch = 0; ch < 3; ++ch) {
          out[u][ch] = cv::saturate_cast<uchar>(board_part + keep * out[u][ch]);
        }
      }
    }
  }
  if (I.opt.noise_sigma > 0) {
    cv::RNG rng(I.opt.seed * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(frame) << 20) ^
                static_cast<std::uint64_t>(cam) ^ 0x5EEDull);
    cv::Mat noise(rgb_out.size(), CV_32FC3);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, I.opt.noise_sigma);
    cv::Mat f;
    rgb_out.convertTo(f, CV_32FC3);
    f += noise;
    f.convertTo(rgb_out, CV_8UC3);
  }
}

}  // namespace vc::sim
