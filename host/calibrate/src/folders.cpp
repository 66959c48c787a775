#include "voxcap/calibrate/folders.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace vc::calibrate {
namespace {

namespace fs = std::filesystem;

// Names compared with their digit runs as numbers: cam2 < cam10.
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      const std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      const std::string ta = na.substr(std::min(na.find_first_not_of('0'), na.size()));
      const std::string tb = nb.substr(std::min(nb.find_first_not_of('0'), nb.size()));
      if (ta.size() != tb.size()) return ta.size() < tb.size();
      if (ta != tb) return ta < tb;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" || ext == ".tiff";
}

cv::Mat read_image(const fs::path& p) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    throw std::runtime_error(p.string() + ": not a regular file");
  if (st.st_size > kMaxImageBytes) throw std::runtime_error(p.string() + ": over 256 MiB");
  cv::Mat img;
  try {
    img = cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(p.string() + ": cannot decode (" + e.msg + ")");
  }
  if (img.empty()) throw std::runtime_error(p.string() + ": cannot decode the image");
  if (img.cols > rig::Camera::kMaxImageSide || img.rows > rig::Camera::kMaxImageSide) {
    throw std::runtime_error(p.string() + ": image over 16384 pixels a side");
  }
  return img;
}

}  // namespace

Capture load_capture(const std::string& dir, const BoardSpec& board, const std::string& floor_name,
                     const std::function<void(int, int)>& progress) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw std::runtime_error(dir + ": not a folder");
  std::vector<std::string> cams;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_directory()) cams.push_back(e.path().filename().string());
    if (static_cast<int>(cams.size()) > kMaxCameras)
      throw std::runtime_error(dir + ": more than 64 camera folders");
  }
  if (ec) throw std::runtime_error(dir + ": cannot list (" + ec.message() + ")");
  if (cams.empty()) throw std::runtime_error(dir + ": no camera folders (expected DIR/<camera>/<frame>.png)");
  std::sort(cams.begin(), cams.end(), natural_less);
  std::vector<std::map<std::string, fs::path>> files(cams.size());
  std::set<std::string, decltype(&natural_less)> frames(&natural_less);
  for (std::size_t c = 0; c < cams.size(); ++c) {
    for (const auto& e : fs::directory_iterator(fs::path(dir) / cams[c], ec)) {
      if (!is_image(e.path())) continue;
      const std::string stem = e.path().stem().string();
      files[c][stem] = e.path();
      frames.insert(stem);
      if (static_cast<int>(frames.size()) > kMaxFrames)
        throw std::runtime_error(dir + ": more than 100000 frames");
    }
    if (ec)
      throw std::runtime_error((fs::path(dir) / cams[c]).string() + ": cannot list (" + ec.message() + ")");
  }
  Capture cap;
  cap.board = board;
  cap.camera_names = cams;
  cap.frame_names.assign(frames.begin(), frames.end());
  const auto it = std::find(cap.frame_names.begin(), cap.frame_names.end(), floor_name);
  cap.floor_frame = it == cap.frame_names.end() ? -1 : static_cast<int>(it - cap.frame_names.begin());
  cap.image_sizes.assign(cams.size(), cv::Size());
  cap.detections.assign(cams.size(), std::vector<Detection>(cap.frame_names.size()));
  int total = 0, done = 0;
  for (const auto& f : files) total += static_cast<int>(f.size());
  for (std::size_t c = 0; c < cams.size(); ++c) {
    for (std::size_t f = 0; f < cap.frame_names.size(); ++f) {
      const auto fi = files[c].find(cap.frame_names[f]);
      if (fi == files[c].end()) continue;
      const cv::Mat img = read_image(fi->second);
      if (cap.image_sizes[c].area() == 0) {
        cap.image_sizes[c] = img.size();
      } else if (cap.image_sizes[c] != img.size()) {
        throw std::runtime_error(fi->second.string() + ": " + std::to_string(img.cols) + "x" +
                                 std::to_string(img.rows) + ", the camera's other images are " +
                                 std::to_string(cap.image_sizes[c].width) + "x" +
                                 std::to_string(cap.image_sizes[c].height));
      }
      cap.detections[c][f] = detect_board(img, board);
      if (progress) progress(++done, total);
    }
    if (cap.image_sizes[c].area() == 0)
      throw std::runtime_error((fs::path(dir) / cams[c]).string() + ": no images");
  }
  return cap;
}

std::string report_text(const Capture& capture, const Solution& s) {
  std::ostringstream o;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "voxcap calibrate solve: %zu cameras, board %s, %d frames used of %zu, %d corners\n",
                s.cameras.size(), capture.board.describe().c_str(), s.frames_used, capture.frame_names.size(),
                s.residuals);
  o << buf;
  std::snprintf(buf, sizeof buf,
                "reprojection RMS %.3f px over all cameras (%d iterations of the bundle adjustment)\n\n",
                s.rms_px, s.iterations);
  o << buf;
  o << "camera        views edge-on  RMS px  max px  coverage  grid in view   fx        fy        cx       "
       "cy\n";
  for (std::size_t c = 0; c < s.cameras.size(); ++c) {
    const CameraReport& r = s.cameras[c];
    const rig::Camera& cam = s.calibration.cameras[c];
    std::snprintf(buf, sizeof buf, "%-12s %6d %7d %7.3f %7.3f %8.0f%% %12.0f%% %9.2f %9.2f %8.2f %8.2f\n",
                  r.name.c_str(), r.views, r.edge_on, r.rms_px, r.max_px, 100 * r.coverage,
                  100 * r.grid_in_view, cam.K(0, 0), cam.K(1, 1), cam.K(0, 2), cam.K(1, 2));
    o << buf;
  }
  o << "\ncoverage of each image (6x6 cells, # = board corners seen there):\n";
  for (int row = 0; row < 6; ++row) {
    for (const CameraReport& r : s.cameras) {
      if (row < static_cast<int>(r.coverage_rows.size()))
        o << "  " << r.coverage_rows[static_cast<std::size_t>(row)] << "   ";
    }
    o << "\n";
  }
  for (const CameraReport& r : s.cameras)
    o << "  " << r.name.substr(0, 6) << std::string(9 - std::min<std::size_t>(6, r.name.size()), ' ');
  o << "\n\n";
  if (s.warnings.empty()) {
    o << "no warnings\n";
  } else {
    for (const std::string& w : s.warnings) o << "warning: " << w << "\n";
  }
  return o.str();
}

cv::Mat report_image(const Solution& s) {
  // Two panels, 480x480 each: from above (x right, y up) and from the side (x right, z up).
  constexpr int kPanel = 480;
  cv::Mat img(kPanel + 40, 2 * kPanel, CV_8UC3, cv::Scalar(255, 255, 255));
  double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
  auto grow = [&](const cv::Vec3d& p) {
    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
  };
  for (const rig::Camera& c : s.calibration.cameras) grow(c.center_world());
  if (s.calibration.grid) {
    grow(s.calibration.grid->min_m);
    grow(s.calibration.grid->max_m());
  }
  grow(cv::Vec3d(0, 0, 0));
  double span = 0;
  for (int i = 0; i < 3; ++i) span = std::max(span, hi[i] - lo[i]);
  span = std::max(span, 0.5) * 1.25;
  const cv::Scalar black(0, 0, 0), grey(160, 160, 160), blue(200, 80, 0), red(0, 0, 220);
  for (int panel = 0; panel < 2; ++panel) {
    const int ax = 0, ay = panel == 0 ? 1 : 2;
    const double cx = (lo[ax] + hi[ax]) / 2, cy = (lo[ay] + hi[ay]) / 2;
    auto to_px = [&](const cv::Vec3d& p) {
      return cv::Point(panel * kPanel + static_cast<int>(kPanel / 2.0 + (p[ax] - cx) / span * kPanel),
                       40 + static_cast<int>(kPanel / 2.0 - (p[ay] - cy) / span * kPanel));
    };
    cv::putText(img, panel == 0 ? "from above (x right, y up)" : "from the side (x right, z up)",
                cv::Point(panel * kPanel + 10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6, black, 1, cv::LINE_AA);
    if (s.calibration.grid) {
      const cv::Vec3d a = s.calibration.grid->min_m, b = s.calibration.grid->max_m();
      cv::rectangle(img, to_px(a), to_px(b), grey, 2);
    }
    cv::drawMarker(img, to_px(cv::Vec3d(0, 0, 0)), black, cv::MARKER_CROSS, 12, 1);
    for (std::size_t c = 0; c < s.calibration.cameras.size(); ++c) {
      const rig::Camera& cam = s.calibration.cameras[c];
      const cv::Vec3d o = cam.center_world();
      const cv::Vec3d dir(cam.R_cam_from_world(2, 0), cam.R_cam_from_world(2, 1), cam.R_cam_from_world(2, 2));
      cv::arrowedLine(img, to_px(o), to_px(o + dir * (0.12 * span)), blue, 2, cv::LINE_AA, 0, 0.25);
      cv::circle(img, to_px(o), 4, red, cv::FILLED, cv::LINE_AA);
      char label[96];
      const double rms = c < s.cameras.size() ? s.cameras[c].rms_px : 0.0;
      std::snprintf(label, sizeof label, "%s %.2f px", cam.name.c_str(), rms);
      cv::putText(img, label, to_px(o) + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1,
                  cv::LINE_AA);
    }
  }
  cv::line(img, cv::Point(kPanel, 0), cv::Point(kPanel, img.rows), grey, 1);
  return img;
}

void write_report(const std::string& dir, const Capture& capture, const Solution& solution) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create (" + ec.message() + ")");
  const fs::path txt = fs::path(dir) / "report.txt";
  std::ofstream f(txt);
  f << report_text(capture, solution);
  if (!f) throw std::runtime_error(txt.string() + ": cannot write");
  const fs::path png = fs::path(dir) / "report.png";
  bool ok = false;
  try {
    ok = cv::imwrite(png.string(), report_image(solution));
  } catch (const cv::Exception& e) {
    throw std::runtime_error(png.string() + ": cannot write (" + e.msg + ")");
  }
  if (!ok) throw std::runtime_error(png.string() + ": cannot write");
}

}  // namespace vc::calibrate
