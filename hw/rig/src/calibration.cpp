// Calibration file I/O: OpenCV FileStorage YAML, one map per camera (cam0 ... camN-1) and an
// optional voxel grid. Every error names the file and the node, because a rig.yaml is edited by hand.
#include "voxcap/rig/calibration.hpp"

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

namespace vc::rig {
namespace {

constexpr const char* kFormat = "voxcap-rig";
constexpr int kVersion = 1;

[[noreturn]] void fail(const std::string& path, const std::string& node, const std::string& what) {
  throw std::runtime_error(path + ": " + (node.empty() ? "" : node + ": ") + what);
}

// A real matrix node with `count` elements (any shape), as doubles in row-major order.
std::vector<double> read_values(const cv::FileNode& n, const std::string& path,
                                const std::string& node, std::size_t count_min,
                                std::size_t count_max) {
  if (n.isNone()) fail(path, node, "missing");
  std::vector<double> values;
  if (n.isSeq()) {
    for (const auto& e : n) {
      if (!e.isReal() && !e.isInt()) fail(path, node, "expected a sequence of numbers");
      values.push_back(static_cast<double>(e));
    }
  } else if (n.isMap()) {
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception&) {
      fail(path, node, "expected an opencv-matrix or a sequence of numbers");
    }
    if (m.empty() || m.channels() != 1) fail(path, node, "expected an opencv-matrix of numbers");
    m.convertTo(m, CV_64F);
    m = m.reshape(1, 1);
    values.assign(m.ptr<double>(), m.ptr<double>() + m.cols);
  } else {
    fail(path, node, "expected an opencv-matrix or a sequence of numbers");
  }
  if (values.size() < count_min || values.size() > count_max) {
    fail(path, node,
         "expected " + std::to_string(count_min) +
             (count_max != count_min ? ".." + std::to_string(count_max) : std::string()) +
             " numbers, got " + std::to_string(values.size()));
  }
  for (double v : values) {
    if (!std::isfinite(v)) fail(path, node, "values must be finite");
  }
  return values;
}

int read_int(const cv::FileNode& n, const std::string& path, const std::string& node) {
  if (n.isNone()) fail(path, node, "missing");
  if (!n.isInt()) fail(path, node, "expected an integer");
  return static_cast<int>(n);
}

double read_real(const cv::FileNode& n, const std::string& path, const std::string& node) {
  if (n.isNone()) fail(path, node, "missing");
  if (!n.isReal() && !n.isInt()) fail(path, node, "expected a number");
  return static_cast<double>(n);
}

Camera read_camera(const cv::FileNode& n, const std::string& path, const std::string& key) {
  if (!n.isMap()) fail(path, key, "expected a map");
  Camera cam;
  const cv::FileNode name = n["name"];
  if (name.isNone()) {
    cam.name = key;
  } else if (name.isString()) {
    cam.name = static_cast<std::string>(name);
  } else {
    fail(path, key + ".name", "expected a string");
  }
  cam.width = read_int(n["width"], path, key + ".width");
  cam.height = read_int(n["height"], path, key + ".height");
  const auto k = read_values(n["K"], path, key + ".K", 9, 9);
  for (int i = 0; i < 9; ++i) cam.K.val[i] = k[i];
  if (!n["dist"].isNone()) {
    // 4 (k1 k2 p1 p2) or 5 coefficients; the rational and thin-prism models are not supported,
    // so longer vectors are accepted only when the extra terms are zero.
    const auto d = read_values(n["dist"], path, key + ".dist", 4, 14);
    for (std::size_t i = 0; i < d.size(); ++i) {
      if (i < 5) {
        cam.dist[static_cast<int>(i)] = d[i];
      } else if (d[i] != 0) {
        fail(path, key + ".dist", "only k1 k2 p1 p2 k3 are supported; coefficient " +
                                      std::to_string(i) + " is not zero");
      }
    }
  }
  if (!n["R"].isNone()) {
    const auto r = read_values(n["R"], path, key + ".R", 9, 9);
    for (int i = 0; i < 9; ++i) cam.R_cam_from_world.val[i] = r[i];
  } else if (!n["rvec"].isNone()) {
    const auto r = read_values(n["rvec"], path, key + ".rvec", 3, 3);
    cv::Rodrigues(cv::Vec3d(r[0], r[1], r[2]), cam.R_cam_from_world);
  } else {
    fail(path, key + ".R", "missing (give R as a 3x3 matrix or rvec as a Rodrigues vector)");
  }
  const auto t = read_values(n["t"], path, key + ".t", 3, 3);
  cam.t_cam_from_world = cv::Vec3d(t[0], t[1], t[2]);
  std::string why;
  if (!cam.valid(&why)) fail(path, key, why);
  return cam;
}

VoxelGrid read_grid(const cv::FileNode& n, const std::string& path) {
  if (!n.isMap()) fail(path, "grid", "expected a map");
  VoxelGrid g;
  const auto mn = read_values(n["min_m"], path, "grid.min_m", 3, 3);
  g.min_m = cv::Vec3d(mn[0], mn[1], mn[2]);
  g.voxel_m = read_real(n["voxel_m"], path, "grid.voxel_m");
  g.nx = read_int(n["nx"], path, "grid.nx");
  g.ny = read_int(n["ny"], path, "grid.ny");
  g.nz = read_int(n["nz"], path, "grid.nz");
  std::string why;
  if (!g.valid(&why)) fail(path, "grid", why);
  return g;
}

}  // namespace

bool Calibration::valid(std::string* why) const {
  if (cameras.empty()) {
    if (why) *why = "no cameras";
    return false;
  }
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    std::string w;
    if (!cameras[k].valid(&w)) {
      if (why) *why = "cam" + std::to_string(k) + ": " + w;
      return false;
    }
  }
  std::string w;
  if (grid && !grid->valid(&w)) {
    if (why) *why = "grid: " + w;
    return false;
  }
  return true;
}

Calibration read_calibration(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) fail(path, "", "no such file");
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML)) {
      fail(path, "", "cannot open as OpenCV FileStorage YAML");
    }
  } catch (const cv::Exception& e) {
    fail(path, "", "not a valid OpenCV FileStorage YAML file (" + e.msg + ")");
  }
  const cv::FileNode root = fs.root();
  if (!root.isMap()) fail(path, "", "expected a YAML map at the top level");
  // format/version are optional (hand-written files may omit them) but must match when present.
  if (!fs["format"].isNone() &&
      (!fs["format"].isString() || static_cast<std::string>(fs["format"]) != kFormat)) {
    fail(path, "format", std::string("expected \"") + kFormat + "\"");
  }
  if (!fs["version"].isNone() && read_int(fs["version"], path, "version") != kVersion) {
    fail(path, "version", "unsupported (this build reads version " + std::to_string(kVersion) + ")");
  }
  Calibration calib;
  int n_cameras = -1;
  if (!fs["num_cameras"].isNone()) {
    n_cameras = read_int(fs["num_cameras"], path, "num_cameras");
    if (n_cameras < 1) fail(path, "num_cameras", "must be at least 1");
  }
  for (int k = 0;; ++k) {
    const std::string key = "cam" + std::to_string(k);
    const cv::FileNode n = fs[key];
    if (n.isNone()) {
      if (n_cameras >= 0 && k < n_cameras) {
        fail(path, key, "missing (num_cameras is " + std::to_string(n_cameras) + ")");
      }
      break;
    }
    if (n_cameras >= 0 && k >= n_cameras) {
      fail(path, key, "present but num_cameras is " + std::to_string(n_cameras));
    }
    calib.cameras.push_back(read_camera(n, path, key));
  }
  if (calib.cameras.empty()) fail(path, "cam0", "missing (no cameras in the file)");
  if (!fs["grid"].isNone()) calib.grid = read_grid(fs["grid"], path);
  return calib;
}

void write_calibration(const std::string& path, const Calibration& calib) {
  std::string why;
  if (!calib.valid(&why)) fail(path, "", "refusing to write an invalid calibration: " + why);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML)) {
      fail(path, "", "cannot open for writing");
    }
  } catch (const cv::Exception& e) {
    fail(path, "", "cannot open for writing (" + e.msg + ")");
  }
  fs.writeComment(
      "voxcap rig calibration (layout: hw/rig/README.md). World: metres, z up. "
      "x_cam = R * x_world + t; OpenCV pinhole model, dist = k1 k2 p1 p2 k3.");
  fs << "format" << kFormat;
  fs << "version" << kVersion;
  fs << "num_cameras" << static_cast<int>(calib.cameras.size());
  for (std::size_t k = 0; k < calib.cameras.size(); ++k) {
    const Camera& cam = calib.cameras[k];
    fs << "cam" + std::to_string(k) << "{";
    fs << "name" << cam.name;
    fs << "width" << cam.width << "height" << cam.height;
    fs << "K" << cv::Mat(cam.K);
    fs << "dist" << cv::Mat(cam.dist).reshape(1, 1);
    fs << "R" << cv::Mat(cam.R_cam_from_world);
    fs << "t" << cv::Mat(cam.t_cam_from_world);
    fs << "}";
  }
  if (calib.grid) {
    const VoxelGrid& g = *calib.grid;
    fs << "grid" << "{";
    fs << "min_m" << "[:" << g.min_m[0] << g.min_m[1] << g.min_m[2] << "]";
    fs << "voxel_m" << g.voxel_m;
    fs << "nx" << g.nx << "ny" << g.ny << "nz" << g.nz;
    fs << "}";
  }
  fs.release();
  if (!std::filesystem::is_regular_file(path)) fail(path, "", "was not written");
}

}  // namespace vc::rig
