// voxcap carve: the edge's subtraction and carving code run over image folders (see carve.hpp for the
// matching rule and how --auto finds its region). The edge's kernels are used only through their public
// headers (edge/core: bgmodel.h, cleanup.h, carver.h); cameras go to them through hw/rig's one C
// conversion (c_models.hpp).
#include "voxcap/calib/carve.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/carver.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/rig/c_models.hpp"
#include "voxcap/rig/input_file.hpp"

namespace vc::calib {
namespace {

namespace fs = std::filesystem;

constexpr std::array<const char*, 9> kImageExts = {".png", ".jpg", ".jpeg", ".bmp", ".ppm",
                                                   ".pgm", ".pnm", ".tif",  ".tiff"};

bool is_image_name(const fs::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return std::find_if(kImageExts.begin(), kImageExts.end(), [&](const char* e) { return ext == e; }) !=
         kImageExts.end();
}

// One camera's frames in `dir` by the matching rule; empty when the camera has none.
std::vector<std::string> frames_of(const fs::path& dir, const std::string& name) {
  std::error_code ec;
  const fs::path sub = dir / name;
  std::vector<std::string> files;
  if (fs::is_directory(sub, ec)) {
    for (fs::directory_iterator it(sub, ec), end; !ec && it != end; it.increment(ec)) {
      if (!is_image_name(it->path())) continue;
      if (static_cast<int>(files.size()) >= kMaxFramesPerCamera)
        throw CarveError(sub.string() + ": more than " + std::to_string(kMaxFramesPerCamera) + " images");
      files.push_back(it->path().string());
    }
    if (ec) throw CarveError(sub.string() + ": cannot list: " + ec.message());
    std::sort(files.begin(), files.end());
    return files;
  }
  for (const char* ext : kImageExts) {
    const fs::path f = dir / (name + ext);
    if (fs::exists(f, ec)) return {f.string()};
  }
  return files;
}

cv::Mat read_image(const std::string& path, int flags, const rig::Camera& cam) {
  const std::string bytes = rig::read_input_file(path, kMaxImageBytes);
  const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  cv::Mat img;
  try {
    img = cv::imdecode(buf, flags);
  } catch (const cv::Exception& e) {
    throw CarveError(path + ": not an image OpenCV can read (" + e.msg + ")");
  }
  if (img.empty()) throw CarveError(path + ": not an image OpenCV can read");
  if (img.cols != cam.width || img.rows != cam.height)
    throw CarveError(path + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                     " pixels, but camera '" + cam.name + "' is calibrated for " + std::to_string(cam.width) +
                     "x" + std::to_string(cam.height));
  if (img.depth() != CV_8U) throw CarveError(path + ": only 8-bit images are read");
  return img;
}

cv::Mat to_rgb(const cv::Mat& img) {
  cv::Mat rgb;
  if (img.channels() == 1)
    cv::cvtColor(img, rgb, cv::COLOR_GRAY2RGB);
  else if (img.channels() == 4)
    cv::cvtColor(img, rgb, cv::COLOR_BGRA2RGB);
  else
    cv::cvtColor(img, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

bool sees(const rig::Camera& c, const cv::Vec3d& p) {
  if (c.to_cam(p)[2] <= 0) return false;
  return c.in_image(c.project(p));
}

// The box of lattice points (n^3 over [lo, hi]) every camera sees; false when none.
bool seen_box(const rig::Calibration& cal, const std::vector<int>& cams, const cv::Vec3d& lo,
              const cv::Vec3d& hi, int n, cv::Vec3d* out_lo, cv::Vec3d* out_hi) {
  const cv::Vec3d step = (hi - lo) * (1.0 / (n - 1));
  bool any = false;
  cv::Vec3d blo(1e300, 1e300, 1e300), bhi(-1e300, -1e300, -1e300);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const cv::Vec3d p(lo[0] + i * step[0], lo[1] + j * step[1], lo[2] + k * step[2]);
        bool all = true;
        for (const int c : cams)
          if (!sees(cal.cameras[static_cast<std::size_t>(c)], p)) {
            all = false;
            break;
          }
        if (!all) continue;
        any = true;
        for (int a = 0; a < 3; ++a) {
          blo[a] = std::min(blo[a], p[a]);
          bhi[a] = std::max(bhi[a], p[a]);
        }
      }
  *out_lo = blo - step;
  *out_hi = bhi + step;
  return any;
}

}  // namespace

bool CarveOptions::valid(std::string* why) const {
  const auto bad = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (images.empty()) return bad("--images DIR is required");
  if (source == MaskSource::Background && background.empty()) return bad("--background DIR is empty");
  if (source == MaskSource::Silhouettes && silhouettes.empty()) return bad("--silhouettes DIR is empty");
  if (source == MaskSource::Threshold && !(threshold >= 0 && threshold < 1))
    return bad("--threshold must be in [0, 1), got " + std::to_string(threshold));
  if (dilate_px < 0 || dilate_px > kMaxMorphologyPx || erode_px < 0 || erode_px > kMaxMorphologyPx)
    return bad("--dilate and --erode must be in [0, " + std::to_string(kMaxMorphologyPx) + "] pixels");
  if (source != MaskSource::Threshold && (dilate_px > 0 || erode_px > 0))
    return bad("--dilate and --erode go with --threshold");
  if (grid) {
    std::string w;
    if (!grid->valid(&w)) return bad("grid: " + w);
    vc_voxel_grid g{};
    char reason[160];
    try {
      g = rig::to_c_grid(*grid);
    } catch (const std::exception& e) {
      return bad(std::string("grid: ") + e.what());
    }
    if (vc_grid_check(&g, reason, sizeof reason) != 0) return bad(std::string("grid: ") + reason);
  }
  if (grid && auto_n) return bad("give either --grid-min/--voxel/--dims or --auto, not both");
  if (auto_n && (auto_n < 2 || auto_n > kMaxAutoVoxels))
    return bad("--auto must be in [2, " + std::to_string(kMaxAutoVoxels) + "], got " +
               std::to_string(auto_n));
  if (why) why->clear();
  return true;
}

rig::VoxelGrid auto_grid(const rig::Calibration& cal, const std::vector<int>& cams, int n) {
  if (cams.empty()) throw CarveError("--auto: no cameras");
  if (n < 2 || n > kMaxAutoVoxels)
    throw CarveError("--auto must be in [2, " + std::to_string(kMaxAutoVoxels) + "]");
  // The point nearest to every optical axis: sum (I - d d^T) (p - c) = 0; the mean centre when the axes
  // are parallel.
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0), mean(0, 0, 0);
  for (const int c : cams) {
    const rig::Camera& cam = cal.cameras[static_cast<std::size_t>(c)];
    const cv::Vec3d C = cam.center_world();
    const cv::Vec3d d = cam.R_cam_from_world.t() * cv::Vec3d(0, 0, 1);
    const cv::Matx33d P = cv::Matx33d::eye() - d * d.t();
    A += P;
    b += P * C;
    mean += C * (1.0 / static_cast<double>(cams.size()));
  }
  cv::Vec3d p0 = mean;
  if (cv::determinant(A) > 1e-9) p0 = A.solve(b, cv::DECOMP_LU);
  double reach = 0;
  for (const int c : cams)
    reach = std::max(reach, cv::norm(cal.cameras[static_cast<std::size_t>(c)].center_world() - p0));
  if (!(reach > 0) || !std::isfinite(reach)) throw CarveError("--auto: the cameras' centres coincide");
  cv::Vec3d lo = p0 - cv::Vec3d(reach, reach, reach), hi = p0 + cv::Vec3d(reach, reach, reach);
  constexpr int kLattice = 96;
  for (int pass = 0; pass < 2; ++pass) {
    cv::Vec3d nlo, nhi;
    if (!seen_box(cal, cams, lo, hi, kLattice, &nlo, &nhi))
      throw CarveError("--auto: no region is seen by all " + std::to_string(cams.size()) +
                       " cameras (sampled within " + std::to_string(reach) +
                       " m of the point nearest their optical axes)");
    for (int a = 0; a < 3; ++a) {  // never grow past the box sampled
      lo[a] = std::max(nlo[a], lo[a]);
      hi[a] = std::min(nhi[a], hi[a]);
    }
  }
  const cv::Vec3d size = hi - lo;
  const double longest = std::max({size[0], size[1], size[2]});
  rig::VoxelGrid g;
  g.voxel_m = longest / n;
  g.nx = std::clamp(static_cast<int>(std::ceil(size[0] / g.voxel_m - 1e-9)), 1, n);
  g.ny = std::clamp(static_cast<int>(std::ceil(size[1] / g.voxel_m - 1e-9)), 1, n);
  g.nz = std::clamp(static_cast<int>(std::ceil(size[2] / g.voxel_m - 1e-9)), 1, n);
  const cv::Vec3d centre = (lo + hi) * 0.5;
  g.min_m = centre - cv::Vec3d(g.nx, g.ny, g.nz) * (g.voxel_m * 0.5);
  return g;
}

cv::Mat threshold_mask(const cv::Mat& bgr, double threshold, int dilate_px, int erode_px) {
  cv::Mat grey;
  if (bgr.channels() == 1)
    grey = bgr;
  else if (bgr.channels() == 4)
    cv::cvtColor(bgr, grey, cv::COLOR_BGRA2GRAY);
  else
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  // Foreground where grey / 255 > threshold: grey > floor(threshold * 255).
  cv::Mat mask;
  cv::threshold(grey, mask, std::floor(threshold * 255.0), 255, cv::THRESH_BINARY);
  if (dilate_px > 0)
    cv::dilate(mask, mask,
               cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * dilate_px + 1, 2 * dilate_px + 1)));
  if (erode_px > 0)
    cv::erode(mask, mask,
              cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * erode_px + 1, 2 * erode_px + 1)));
  return mask;
}

bool Hull::bounds(int lo[3], int hi[3]) const {
  bool any = false;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<int>::max();
    hi[a] = -1;
  }
  for (int k = 0; k < grid.nz; ++k)
    for (int j = 0; j < grid.ny; ++j)
      for (int i = 0; i < grid.nx; ++i) {
        if (!rig::hull_bit(bits.data(), grid.index(i, j, k))) continue;
        any = true;
        const int v[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], v[a]);
          hi[a] = std::max(hi[a], v[a]);
        }
      }
  return any;
}

struct CarveSession::Impl {
  struct Cam {
    std::vector<std::string> images, masks;
    vc_bgmodel* model = nullptr;
  };
  std::vector<Cam> cams;
  std::vector<vc_carver*> carvers;  // pair p carves matched cameras 2p and 2p+1 (the last alone if odd)
  std::vector<std::uint8_t> scratch;
  ~Impl() {
    for (Cam& c : cams) vc_bgmodel_free(c.model);
    for (vc_carver* c : carvers) vc_carver_free(c);
  }
};

CarveSession::CarveSession(const rig::Calibration& calibration, const CarveOptions& options)
    : impl_(std::make_unique<Impl>()), calibration_(calibration), options_(options) {
  std::string why;
  if (!options.valid(&why)) throw CarveError(why);
  if (!calibration.valid(&why)) throw CarveError("calibration: " + why);
  std::error_code ec;
  const auto check_dir = [&](const std::string& d, const char* opt) {
    if (!fs::is_directory(d, ec)) throw CarveError(std::string(opt) + " " + d + ": not a folder");
  };
  check_dir(options.images, "--images");
  if (options.source == MaskSource::Background) check_dir(options.background, "--background");
  if (options.source == MaskSource::Silhouettes) check_dir(options.silhouettes, "--silhouettes");

  for (std::size_t c = 0; c < calibration.cameras.size(); ++c) {
    const std::string& name = calibration.cameras[c].name;
    std::vector<std::string> files = frames_of(options.images, name);
    if (files.empty()) {
      skipped_.push_back(name);
      continue;
    }
    if (frames_ == 0) frames_ = static_cast<int>(files.size());
    if (static_cast<int>(files.size()) != frames_)
      throw CarveError("--images: camera '" + name + "' has " + std::to_string(files.size()) +
                       " frames, camera '" +
                       calibration.cameras[static_cast<std::size_t>(cameras_.front())].name + "' has " +
                       std::to_string(frames_));
    Impl::Cam cam;
    cam.images = std::move(files);
    if (options.source == MaskSource::Silhouettes) {
      cam.masks = frames_of(options.silhouettes, name);
      if (cam.masks.size() != cam.images.size())
        throw CarveError("--silhouettes: camera '" + name + "' has " + std::to_string(cam.masks.size()) +
                         " masks for " + std::to_string(cam.images.size()) + " frames");
    }
    cameras_.push_back(static_cast<int>(c));
    impl_->cams.push_back(std::move(cam));
  }
  if (cameras_.size() < 2)
    throw CarveError(
        "--images " + options.images + ": images for " + std::to_string(cameras_.size()) +
        " camera(s) of the calibration; at least 2 are needed (DIR/NAME/ or DIR/NAME.png per camera name)");

  if (options.source == MaskSource::Background) {
    vc_subtract_params params;
    vc_subtract_params_default(&params);
    for (std::size_t m = 0; m < cameras_.size(); ++m) {
      const rig::Camera& cam = calibration.cameras[static_cast<std::size_t>(cameras_[m])];
      const std::vector<std::string> bg = frames_of(options.background, cam.name);
      if (bg.empty())
        throw CarveError("--background " + options.background + ": no frames for camera '" + cam.name + "'");
      char reason[160];
      if (vc_bgmodel_new(cam.width, cam.height, &impl_->cams[m].model, reason, sizeof reason) != 0)
        throw CarveError("camera '" + cam.name + "': " + reason);
      for (std::size_t f = 0; f < std::max<std::size_t>(bg.size(), 2);
           ++f) {  // one frame: learnt twice (sigma floor)
        const cv::Mat rgb = to_rgb(read_image(bg[f % bg.size()], cv::IMREAD_COLOR, cam));
        if (vc_bgmodel_learn(impl_->cams[m].model, rgb.data, rgb.step) != 0)
          throw CarveError("--background: camera '" + cam.name + "': the model took no more frames");
        if (f >= VC_BACKGROUND_FRAMES_MAX) break;
      }
      if (vc_bgmodel_finish(impl_->cams[m].model) != 0 ||
          vc_bgmodel_set_params(impl_->cams[m].model, &params) != 0)
        throw CarveError("--background: camera '" + cam.name + "': cannot build the background model");
    }
  }

  if (options.grid)
    grid_ = *options.grid;
  else if (options.auto_n)
    grid_ = auto_grid(calibration, cameras_, options.auto_n);
  else if (calibration.grid)
    grid_ = *calibration.grid;
  else
    throw CarveError(
        "no grid: give --grid-min X Y Z --voxel S --dims NX NY NZ, or --auto N (the calibration has none)");
  const vc_voxel_grid g = rig::to_c_grid(grid_);
  char reason[160];
  if (vc_grid_check(&g, reason, sizeof reason) != 0) throw CarveError(std::string("grid: ") + reason);
  for (std::size_t m = 0; m < cameras_.size(); m += 2) {
    const std::size_t m1 = std::min(m + 1, cameras_.size() - 1);
    const vc_camera c0 = rig::to_c_camera(calibration.cameras[static_cast<std::size_t>(cameras_[m])]);
    const vc_camera c1 = rig::to_c_camera(calibration.cameras[static_cast<std::size_t>(cameras_[m1])]);
    vc_carver* carver = nullptr;
    if (vc_carver_new(&g, &c0, &c1, options.rule, &carver, reason, sizeof reason) != 0)
      throw CarveError("carver for cameras '" +
                       calibration.cameras[static_cast<std::size_t>(cameras_[m])].name + "' and '" +
                       calibration.cameras[static_cast<std::size_t>(cameras_[m1])].name + "': " + reason);
    impl_->carvers.push_back(carver);
  }
}

CarveSession::~CarveSession() = default;

std::string CarveSession::frame_name(int f) const {
  return fs::path(impl_->cams.front().images[static_cast<std::size_t>(f)]).stem().string();
}

Hull CarveSession::carve(int f, std::vector<cv::Mat>* masks_out) {
  if (f < 0 || f >= frames_) throw CarveError("frame " + std::to_string(f) + " out of range");
  std::vector<cv::Mat> masks(cameras_.size());
  for (std::size_t m = 0; m < cameras_.size(); ++m) {
    const rig::Camera& cam = calibration_.cameras[static_cast<std::size_t>(cameras_[m])];
    Impl::Cam& c = impl_->cams[m];
    const std::size_t fi = static_cast<std::size_t>(f);
    switch (options_.source) {
      case MaskSource::Silhouettes: {
        cv::Mat sil = read_image(c.masks[fi], cv::IMREAD_GRAYSCALE, cam);
        cv::compare(sil, 0, masks[m], cv::CMP_GT);
        break;
      }
      case MaskSource::Threshold:
        masks[m] = threshold_mask(read_image(c.images[fi], cv::IMREAD_UNCHANGED, cam), options_.threshold,
                                  options_.dilate_px, options_.erode_px);
        break;
      case MaskSource::Background: {
        const cv::Mat rgb = to_rgb(read_image(c.images[fi], cv::IMREAD_COLOR, cam));
        masks[m] = cv::Mat(cam.height, cam.width, CV_8U);
        const std::size_t need = vc_cleanup_radius_scratch_size(cam.width, VC_CLEANUP_RADIUS_PX);
        if (impl_->scratch.size() < need) impl_->scratch.resize(need);
        // The edge's sequence (subtraction, clean-up, limb-scale cue), as the edge daemon runs it.
        if (vc_mask_frame(c.model, rgb.data, rgb.step, masks[m].data, VC_CLEANUP_RADIUS_PX,
                          impl_->scratch.data(), impl_->scratch.size(), nullptr) != 0)
          throw CarveError("camera '" + cam.name + "': subtraction failed");
        break;
      }
    }
    if (!masks[m].isContinuous()) masks[m] = masks[m].clone();
  }
  Hull hull;
  hull.grid = grid_;
  hull.bits.assign(grid_.bitset_bytes(), 0xff);
  std::vector<std::uint8_t> part(vc_carver_bitset_bytes(impl_->carvers.front()));
  for (std::size_t p = 0; p < impl_->carvers.size(); ++p) {
    const std::size_t m0 = 2 * p, m1 = std::min(2 * p + 1, cameras_.size() - 1);
    if (vc_carver_run(impl_->carvers[p], masks[m0].data, masks[m1].data, part.data(), nullptr) != 0)
      throw CarveError("carving failed");
    for (std::size_t b = 0; b < part.size(); ++b) hull.bits[b] &= part[b];
  }
  const std::size_t n = grid_.count();
  for (std::size_t idx = 0; idx < n; ++idx) hull.occupied += rig::hull_bit(hull.bits.data(), idx);
  if (masks_out) *masks_out = std::move(masks);
  return hull;
}

void write_npy(const std::string& path, const Hull& hull) {
  const std::size_t n = hull.grid.count();
  std::string header = "{'descr': '|b1', 'fortran_order': False, 'shape': (" + std::to_string(n) + ",), }";
  const std::size_t unpadded = 10 + header.size() + 1;  // magic 6 + version 2 + length 2, then '\n'
  header.append((64 - unpadded % 64) % 64, ' ');
  header.push_back('\n');
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot write");
  const char magic[8] = {'\x93', 'N', 'U', 'M', 'P', 'Y', 1, 0};
  out.write(magic, 8);
  const auto len = static_cast<std::uint16_t>(header.size());
  const char len_le[2] = {static_cast<char>(len & 0xff), static_cast<char>(len >> 8)};
  out.write(len_le, 2);
  out << header;
  std::vector<char> data(n);
  for (std::size_t i = 0; i < n; ++i) data[i] = static_cast<char>(rig::hull_bit(hull.bits.data(), i));
  out.write(data.data(), static_cast<std::streamsize>(n));
  if (!out) throw std::runtime_error(path + ": write failed");
}

void write_ply(const std::string& path, const Hull& hull) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot write");
  const rig::VoxelGrid& g = hull.grid;
  out << "ply\nformat binary_little_endian 1.0\ncomment voxcap carve: occupied voxel centres, world metres\n"
      << "comment grid min " << g.min_m[0] << " " << g.min_m[1] << " " << g.min_m[2] << " voxel " << g.voxel_m
      << " dims " << g.nx << " " << g.ny << " " << g.nz << "\n"
      << "element vertex " << hull.occupied
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        if (!rig::hull_bit(hull.bits.data(), g.index(i, j, k))) continue;
        const cv::Vec3d c = g.center(i, j, k);
        const float v[3] = {static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2])};
        char le[12];
        std::memcpy(le, v, sizeof le);  // x86-64 and aarch64 are little-endian
        out.write(le, sizeof le);
      }
  if (!out) throw std::runtime_error(path + ": write failed");
}

void write_preview(const std::string& path, const Hull& hull) {
  const rig::VoxelGrid& g = hull.grid;
  cv::Mat top(g.ny, g.nx, CV_8U, cv::Scalar(0)), front(g.nz, g.nx, CV_8U, cv::Scalar(0)),
      side(g.nz, g.ny, CV_8U, cv::Scalar(0));
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        if (!rig::hull_bit(hull.bits.data(), g.index(i, j, k))) continue;
        top.at<std::uint8_t>(g.ny - 1 - j, i) = 255;
        front.at<std::uint8_t>(g.nz - 1 - k, i) = 255;
        side.at<std::uint8_t>(g.nz - 1 - k, j) = 255;
      }
  const int longest = std::max({g.nx, g.ny, g.nz});
  const int scale = std::max(1, (256 + longest - 1) / longest);
  std::vector<cv::Mat> panels;
  int height = 0;
  for (const cv::Mat& m : {top, front, side}) {
    cv::Mat big;
    cv::resize(m, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
    height = std::max(height, big.rows);
    panels.push_back(big);
  }
  int width = 0;
  for (const cv::Mat& p : panels) width += p.cols + 4;
  cv::Mat canvas(height, width - 4, CV_8U, cv::Scalar(96));
  int x = 0;
  for (const cv::Mat& p : panels) {
    p.copyTo(canvas(cv::Rect(x, height - p.rows, p.cols, p.rows)));
    x += p.cols + 4;
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path, canvas);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": cannot write the preview (" + e.msg + ")");
  }
  if (!ok) throw std::runtime_error(path + ": cannot write the preview");
}

}  // namespace vc::calib
