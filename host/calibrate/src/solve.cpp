// The solve, step by step (the header says what and why):
// 1. Views: a camera's detection with at least min_corners corners. Per camera, cv::calibrateCamera on its
//    views (k3 held at 0 here, freed in the adjustment) gives intrinsics and the board pose in every view;
//    a view whose board normal is more than edge_on_deg from the line of sight is dropped (its corners lie
//    near a line and say little).
// 2. Extrinsics: cameras are nodes, edges weighted by the frames both see; a maximum spanning tree from the
//    camera with the most views chains T_b_from_a = T_b_from_board · T_board_from_a (the chordal mean of
//    the shared frames' rotations, the mean of their translations) out to every camera. Every frame's
//    board pose in the reference camera's frame comes from the camera that sees most of its corners.
// 3. Bundle adjustment (Ceres): residual = detected corner - OpenCV projection of the board corner through
//    board pose and camera (9 intrinsics fx fy cx cy k1 k2 p1 p2 k3, 6 extrinsics), Huber loss, the
//    reference camera's extrinsics held (gauge), the board's size fixes the scale. Schur elimination of the
//    board poses.
// 4. World frame: the floor frame's board pose, its z turned up (R_board_from_world = diag(1, -1, -1)).
// Limits: one board; no rolling shutter; lens models other than k1 k2 p1 p2 k3 are not fitted.
#include "voxcap/calibrate/solve.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>

namespace vc::calibrate {
namespace {

constexpr int kGrid = 6;  // coverage grid cells per image side
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct Pose {  // p_to = R p_from + t
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t{0, 0, 0};
  Pose inv() const { return {R.t(), -(R.t() * t)}; }
  Pose operator*(const Pose& o) const { return {R * o.R, R * o.t + t}; }
};

Pose from_rvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  Pose p;
  cv::Rodrigues(rvec, p.R);
  p.t = cv::Vec3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return p;
}

void to_params(const Pose& p, double* out6) {
  cv::Vec3d r;
  cv::Rodrigues(p.R, r);
  for (int i = 0; i < 3; ++i) out6[i] = r[i], out6[3 + i] = p.t[i];
}

Pose from_params(const double* in6) {
  Pose p;
  cv::Rodrigues(cv::Vec3d(in6[0], in6[1], in6[2]), p.R);
  p.t = cv::Vec3d(in6[3], in6[4], in6[5]);
  return p;
}

cv::Matx33d nearest_rotation(const cv::Matx33d& M) {
  cv::SVD svd(cv::Mat(M), cv::SVD::FULL_UV);
  cv::Mat R = svd.u * svd.vt;
  if (cv::determinant(R) < 0) {
    cv::Mat D = cv::Mat::eye(3, 3, CV_64F);
    D.at<double>(2, 2) = -1;
    R = svd.u * D * svd.vt;
  }
  return cv::Matx33d(R);
}

// Corner (X, Y, 0) on the board -> pixel through board pose (in the reference camera's frame), camera
// extrinsics (reference -> camera) and OpenCV's pinhole + k1 k2 p1 p2 k3 model.
struct CornerResidual {
  double u, v, X, Y;
  template <typename T>
  bool operator()(const T* intr, const T* cam, const T* board, T* r) const {
    const T pb[3] = {T(X), T(Y), T(0)};
    T pref[3];
    ceres::AngleAxisRotatePoint(board, pb, pref);
    for (int i = 0; i < 3; ++i) pref[i] += board[3 + i];
    T pc[3];
    ceres::AngleAxisRotatePoint(cam, pref, pc);
    for (int i = 0; i < 3; ++i) pc[i] += cam[3 + i];
    const T x = pc[0] / pc[2], y = pc[1] / pc[2];
    const T r2 = x * x + y * y;
    const T radial = T(1) + intr[4] * r2 + intr[5] * r2 * r2 + intr[8] * r2 * r2 * r2;
    const T xd = x * radial + T(2) * intr[6] * x * y + intr[7] * (r2 + T(2) * x * x);
    const T yd = y * radial + intr[6] * (r2 + T(2) * y * y) + T(2) * intr[7] * x * y;
    r[0] = intr[0] * xd + intr[2] - T(u);
    r[1] = intr[1] * yd + intr[3] - T(v);
    return true;
  }
};

struct View {
  int cam = 0, frame = 0;
  const Detection* det = nullptr;
  Pose cam_from_board;  // from the per-camera calibration
};

}  // namespace

bool SolveOptions::valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (min_views < 3) return fail("min_views must be >= 3");
  if (min_corners < 4) return fail("min_corners must be >= 4");
  if (!(edge_on_deg > 0 && edge_on_deg <= 90)) return fail("edge_on_deg must be in (0, 90]");
  if (!(huber_px > 0)) return fail("huber_px must be > 0");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (grid && !grid->valid(why)) return false;
  return true;
}

double grid_in_view(const rig::Camera& camera, const rig::VoxelGrid& grid) {
  const cv::Vec3d lo = grid.min_m, hi = grid.max_m();
  int in = 0, all = 0;
  constexpr int n = 9;
  for (int face = 0; face < 6; ++face) {
    const int axis = face / 2;
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        cv::Vec3d p;
        const int ua = (axis + 1) % 3, ub = (axis + 2) % 3;
        p[axis] = face % 2 ? hi[axis] : lo[axis];
        p[ua] = lo[ua] + (hi[ua] - lo[ua]) * a / (n - 1);
        p[ub] = lo[ub] + (hi[ub] - lo[ub]) * b / (n - 1);
        ++all;
        if (camera.to_cam(p)[2] > 0 && camera.in_image(camera.project(p))) ++in;
      }
    }
  }
  return static_cast<double>(in) / all;
}

Solution solve(const Capture& cap, const SolveOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument("calibrate: " + why);
  if (!cap.board.valid(&why)) throw std::invalid_argument(why);
  const int n_cam = static_cast<int>(cap.camera_names.size());
  const int n_frames = static_cast<int>(cap.frame_names.size());
  if (n_cam < 1 || static_cast<int>(cap.detections.size()) != n_cam ||
      static_cast<int>(cap.image_sizes.size()) != n_cam) {
    throw std::invalid_argument("calibrate: capture has inconsistent camera lists");
  }
  if (n_cam < 2)
    throw DegenerateCapture("calibrate: a rig needs at least 2 cameras, the capture has " +
                            std::to_string(n_cam));
  for (const auto& d : cap.detections) {
    if (static_cast<int>(d.size()) != n_frames)
      throw std::invalid_argument("calibrate: capture has inconsistent frame lists");
  }
  const std::vector<cv::Point3d> corners = cap.board.corners_board();
  const int n_corner_ids = static_cast<int>(corners.size());

  // 1. Per camera: views, intrinsics, board poses, edge-on views dropped.
  std::vector<cv::Matx33d> K(static_cast<std::size_t>(n_cam));
  std::vector<cv::Vec<double, 5>> dist(static_cast<std::size_t>(n_cam));
  std::vector<std::vector<View>> views(static_cast<std::size_t>(n_cam));
  Solution sol;
  sol.cameras.resize(static_cast<std::size_t>(n_cam));
  for (int c = 0; c < n_cam; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    CameraReport& rep = sol.cameras[cu];
    rep.name = cap.camera_names[cu];
    std::vector<std::vector<cv::Point3f>> obj;
    std::vector<std::vector<cv::Point2f>> img;
    std::vector<int> frame_of;
    int seen = 0;
    for (int f = 0; f < n_frames; ++f) {
      const Detection& d = cap.detections[cu][static_cast<std::size_t>(f)];
      if (d.ids.size() != d.image_px.size())
        throw std::invalid_argument("calibrate: a detection's ids and points differ in number");
      if (!d.empty()) ++seen;
      if (static_cast<int>(d.ids.size()) < opt.min_corners) continue;
      std::vector<cv::Point3f> o;
      std::vector<cv::Point2f> i;
      for (std::size_t k = 0; k < d.ids.size(); ++k) {
        if (d.ids[k] < 0 || d.ids[k] >= n_corner_ids)
          throw std::invalid_argument("calibrate: a corner id is off the board");
        const cv::Point3d& p = corners[static_cast<std::size_t>(d.ids[k])];
        o.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y), 0.f);
        i.emplace_back(static_cast<float>(d.image_px[k].x), static_cast<float>(d.image_px[k].y));
      }
      // Corners all on one line (a row of the board) fix no pose. A board seen edge-on: the affine map from
      // board to image squeezes one direction by cos(angle from facing); its singular values say so before
      // any intrinsics exist.
      cv::Matx22d so_ = cv::Matx22d::zeros(), si_ = cv::Matx22d::zeros();
      cv::Point2d om(0, 0), im(0, 0);
      for (std::size_t k = 0; k < o.size(); ++k) om += cv::Point2d(o[k].x, o[k].y), im += cv::Point2d(i[k]);
      om *= 1.0 / static_cast<double>(o.size());
      im *= 1.0 / static_cast<double>(o.size());
      for (std::size_t k = 0; k < o.size(); ++k) {
        const cv::Vec2d a(o[k].x - om.x, o[k].y - om.y), b(i[k].x - im.x, i[k].y - im.y);
        so_ += a * a.t();
        si_ += b * a.t();
      }
      if (cv::determinant(so_) < 1e-6 * std::pow(cap.board.square_m, 4)) continue;
      const cv::Matx22d A = si_ * so_.inv();
      cv::Vec2d sv;
      cv::SVD::compute(A, sv);
      if (!(sv[0] > 0) || sv[1] / sv[0] < std::cos(opt.edge_on_deg / kRadToDeg)) {
        ++rep.edge_on;
        continue;
      }
      obj.push_back(std::move(o));
      img.push_back(std::move(i));
      frame_of.push_back(f);
    }
    if (seen == 0) {
      throw DegenerateCapture("calibrate: " + rep.name + " never sees the board (0 of " +
                              std::to_string(n_frames) + " frames)");
    }
    if (obj.empty() && rep.edge_on > 0) {
      throw DegenerateCapture("calibrate: " + rep.name + " sees the board only edge-on (" +
                              std::to_string(rep.edge_on) + " views more than " +
                              std::to_string(static_cast<int>(opt.edge_on_deg)) +
                              " degrees from facing it): turn the board towards it");
    }
    if (static_cast<int>(obj.size()) < opt.min_views) {
      throw DegenerateCapture("calibrate: " + rep.name + ": " + std::to_string(obj.size()) +
                              " usable board views (" + std::to_string(opt.min_corners) +
                              "+ corners, not on one line), at least " + std::to_string(opt.min_views) +
                              " needed");
    }
    cv::Mat Kc, dc;
    std::vector<cv::Mat> rv, tv;
    try {
      cv::calibrateCamera(obj, img, cap.image_sizes[cu], Kc, dc, rv, tv, cv::CALIB_FIX_K3);
    } catch (const cv::Exception& e) {
      throw DegenerateCapture("calibrate: " + rep.name + ": intrinsics failed (" + e.err + ")");
    }
    K[cu] = cv::Matx33d(Kc);
    for (int k = 0; k < 5; ++k) dist[cu][k] = dc.at<double>(k);
    for (std::size_t v = 0; v < obj.size(); ++v) {
      const Pose p = from_rvec(rv[v], tv[v]);
      views[cu].push_back({c, frame_of[v], &cap.detections[cu][static_cast<std::size_t>(frame_of[v])], p});
    }
    rep.views = static_cast<int>(views[cu].size());
  }

  // 2. The spanning tree over cameras.
  std::vector<std::map<int, const View*>> by_frame(static_cast<std::size_t>(n_cam));
  for (int c = 0; c < n_cam; ++c) {
    for (const View& v : views[static_cast<std::size_t>(c)])
      by_frame[static_cast<std::size_t>(c)][v.frame] = &v;
  }
  auto shared = [&](int a, int b) {
    std::vector<std::pair<const View*, const View*>> s;
    for (const auto& [f, va] : by_frame[static_cast<std::size_t>(a)]) {
      const auto it = by_frame[static_cast<std::size_t>(b)].find(f);
      if (it != by_frame[static_cast<std::size_t>(b)].end()) s.emplace_back(va, it->second);
    }
    return s;
  };
  int ref = 0;
  for (int c = 1; c < n_cam; ++c) {
    if (views[static_cast<std::size_t>(c)].size() > views[static_cast<std::size_t>(ref)].size()) ref = c;
  }
  std::vector<std::optional<Pose>> cam_from_ref(static_cast<std::size_t>(n_cam));
  cam_from_ref[static_cast<std::size_t>(ref)] = Pose{};
  for (int added = 1; added < n_cam; ++added) {
    int best_a = -1, best_b = -1;
    std::size_t best_n = 0;
    for (int a = 0; a < n_cam; ++a) {
      if (!cam_from_ref[static_cast<std::size_t>(a)]) continue;
      for (int b = 0; b < n_cam; ++b) {
        if (cam_from_ref[static_cast<std::size_t>(b)]) continue;
        const std::size_t n = shared(a, b).size();
        if (n > best_n) best_n = n, best_a = a, best_b = b;
      }
    }
    if (best_b < 0) {
      for (int b = 0; b < n_cam; ++b) {
        if (!cam_from_ref[static_cast<std::size_t>(b)]) {
          throw DegenerateCapture("calibrate: " + cap.camera_names[static_cast<std::size_t>(b)] +
                                  " shares no board view with " +
                                  cap.camera_names[static_cast<std::size_t>(ref)] +
                                  "'s group of cameras: show the board to it and a neighbour at once");
        }
      }
    }
    cv::Matx33d Rsum = cv::Matx33d::zeros();
    cv::Vec3d tsum(0, 0, 0);
    const auto s = shared(best_a, best_b);
    for (const auto& [va, vb] : s) {
      const Pose b_from_a = vb->cam_from_board * va->cam_from_board.inv();
      Rsum += b_from_a.R;
      tsum += b_from_a.t;
    }
    const Pose b_from_a{nearest_rotation(Rsum), tsum / static_cast<double>(s.size())};
    cam_from_ref[static_cast<std::size_t>(best_b)] =
        b_from_a * *cam_from_ref[static_cast<std::size_t>(best_a)];
  }

  // Frames used, each board pose in the reference frame from its best view.
  std::vector<int> frame_slot(static_cast<std::size_t>(n_frames), -1);
  std::vector<std::array<double, 6>> board_params;
  for (int f = 0; f < n_frames; ++f) {
    const View* best = nullptr;
    for (int c = 0; c < n_cam; ++c) {
      const auto it = by_frame[static_cast<std::size_t>(c)].find(f);
      if (it != by_frame[static_cast<std::size_t>(c)].end() &&
          (!best || it->second->det->ids.size() > best->det->ids.size())) {
        best = it->second;
      }
    }
    if (!best) continue;
    frame_slot[static_cast<std::size_t>(f)] = static_cast<int>(board_params.size());
    board_params.emplace_back();
    to_params(cam_from_ref[static_cast<std::size_t>(best->cam)]->inv() * best->cam_from_board,
              board_params.back().data());
  }
  if (cap.floor_frame < 0 || cap.floor_frame >= n_frames ||
      frame_slot[static_cast<std::size_t>(cap.floor_frame)] < 0) {
    const std::string name = cap.floor_frame >= 0 && cap.floor_frame < n_frames
                                 ? "'" + cap.frame_names[static_cast<std::size_t>(cap.floor_frame)] + "'"
                                 : "(none in the capture)";
    throw DegenerateCapture("calibrate: no camera sees the board on the floor (frame " + name +
                            "): it sets the world frame");
  }
  sol.frames_used = static_cast<int>(board_params.size());

  // 3. Bundle adjustment.
  std::vector<std::array<double, 9>> intr(static_cast<std::size_t>(n_cam));
  std::vector<std::array<double, 6>> extr(static_cast<std::size_t>(n_cam));
  for (int c = 0; c < n_cam; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    intr[cu] = {K[cu](0, 0), K[cu](1, 1), K[cu](0, 2), K[cu](1, 2), dist[cu][0],
                dist[cu][1], dist[cu][2], dist[cu][3], dist[cu][4]};
    to_params(*cam_from_ref[cu], extr[cu].data());
  }
  ceres::Problem problem;
  for (int c = 0; c < n_cam; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    for (const View& v : views[cu]) {
      double* board =
          board_params[static_cast<std::size_t>(frame_slot[static_cast<std::size_t>(v.frame)])].data();
      for (std::size_t k = 0; k < v.det->ids.size(); ++k) {
        const cv::Point3d& p = corners[static_cast<std::size_t>(v.det->ids[k])];
        auto* cost = new ceres::AutoDiffCostFunction<CornerResidual, 2, 9, 6, 6>(
            new CornerResidual{v.det->image_px[k].x, v.det->image_px[k].y, p.x, p.y});
        problem.AddResidualBlock(cost, new ceres::HuberLoss(opt.huber_px), intr[cu].data(), extr[cu].data(),
                                 board);
        ++sol.residuals;
      }
    }
  }
  problem.SetParameterBlockConstant(extr[static_cast<std::size_t>(ref)].data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = opt.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  sol.iterations = static_cast<int>(summary.iterations.size());
  if (!summary.IsSolutionUsable())
    throw DegenerateCapture("calibrate: the bundle adjustment failed: " + summary.message);

  // 4. World frame and the result.
  const Pose ref_from_floor = from_params(
      board_params[static_cast<std::size_t>(frame_slot[static_cast<std::size_t>(cap.floor_frame)])].data());
  const Pose floor_from_world{cv::Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1), cv::Vec3d(0, 0, 0)};
  double sum2_all = 0;
  int n_all = 0;
  for (int c = 0; c < n_cam; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    rig::Camera cam;
    cam.name = cap.camera_names[cu];
    cam.width = cap.image_sizes[cu].width;
    cam.height = cap.image_sizes[cu].height;
    const auto& in = intr[cu];
    cam.K = cv::Matx33d(in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1);
    cam.dist = cv::Vec<double, 5>(in[4], in[5], in[6], in[7], in[8]);
    const Pose cw = from_params(extr[cu].data()) * ref_from_floor * floor_from_world;
    cam.R_cam_from_world = cw.R;
    cam.t_cam_from_world = cw.t;
    CameraReport& rep = sol.cameras[cu];
    // Reprojection errors and the image coverage.
    double sum2 = 0;
    int n = 0;
    std::array<bool, kGrid * kGrid> cells{};
    const Pose world_from_ref = (ref_from_floor * floor_from_world).inv();
    for (const View& v : views[cu]) {
      const Pose world_from_board =
          world_from_ref *
          from_params(
              board_params[static_cast<std::size_t>(frame_slot[static_cast<std::size_t>(v.frame)])].data());
      for (std::size_t k = 0; k < v.det->ids.size(); ++k) {
        const cv::Point3d& p = corners[static_cast<std::size_t>(v.det->ids[k])];
        const cv::Point2d px =
            cam.project(world_from_board.R * cv::Vec3d(p.x, p.y, p.z) + world_from_board.t);
        const double e = cv::norm(px - v.det->image_px[k]);
        sum2 += e * e;
        ++n;
        rep.max_px = std::max(rep.max_px, e);
        const int gx = std::clamp(static_cast<int>(v.det->image_px[k].x * kGrid / cam.width), 0, kGrid - 1);
        const int gy = std::clamp(static_cast<int>(v.det->image_px[k].y * kGrid / cam.height), 0, kGrid - 1);
        cells[(static_cast<std::size_t>(gy) * std::size_t{kGrid} + static_cast<std::size_t>(gx))] = true;
      }
    }
    rep.rms_px = std::sqrt(sum2 / std::max(1, n));
    sum2_all += sum2;
    n_all += n;
    rep.coverage = static_cast<double>(std::count(cells.begin(), cells.end(), true)) / (kGrid * kGrid);
    for (int gy = 0; gy < kGrid; ++gy) {
      std::string row;
      for (int gx = 0; gx < kGrid; ++gx)
        row += cells[(static_cast<std::size_t>(gy) * std::size_t{kGrid} + static_cast<std::size_t>(gx))]
                   ? '#'
                   : '.';
      rep.coverage_rows.push_back(row);
    }
    if (rep.views < opt.warn_views || rep.coverage < opt.warn_coverage) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "poorly constrained: %d views, %.0f %% of the image covered (want %d+ views, %.0f %%+)",
                    rep.views, 100 * rep.coverage, opt.warn_views, 100 * opt.warn_coverage);
      rep.warnings.emplace_back(buf);
    }
    if (opt.grid) {
      rep.grid_in_view = grid_in_view(cam, *opt.grid);
      if (rep.grid_in_view < 1.0) {
        char buf[160];
        std::snprintf(buf, sizeof buf,
                      "the voxel grid is not inside its view (%.0f %% of the grid's boundary points seen)",
                      100 * rep.grid_in_view);
        rep.warnings.emplace_back(buf);
      }
    }
    for (const std::string& w : rep.warnings) sol.warnings.push_back(rep.name + ": " + w);
    sol.calibration.cameras.push_back(cam);
  }
  sol.rms_px = std::sqrt(sum2_all / std::max(1, n_all));
  sol.calibration.grid = opt.grid;
  if (!sol.calibration.valid(&why))
    throw DegenerateCapture("calibrate: the solution is not a valid rig: " + why);
  return sol;
}

}  // namespace vc::calibrate
