#include "voxcap/calibrate/capture.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/calibrate/solve.hpp"

namespace vc::calibrate {

namespace fs = std::filesystem;

bool CaptureOptions::valid(std::string* why) const {
  if (min_corners < 4) {
    if (why) *why = fmt::format("min_corners {} is under 4", min_corners);
    return false;
  }
  if (cells < 1 || cells > 16) {
    if (why) *why = fmt::format("cells {} is not in 1..16", cells);
    return false;
  }
  return true;
}

CaptureRecorder::CaptureRecorder(fs::path out, std::vector<CaptureCamera> cameras, BoardSpec board,
                                 CaptureOptions options)
    : out_(std::move(out)), cams_(std::move(cameras)), board_(std::move(board)), opt_(options) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("capture: " + why);
  if (cams_.empty()) throw std::invalid_argument("capture: no cameras");
  const size_t cells = static_cast<size_t>(opt_.cells) * static_cast<size_t>(opt_.cells);
  views_.assign(cams_.size(), 0);
  cover_.assign(cams_.size(), std::vector<bool>(cells, false));
  for (const CaptureCamera& c : cams_) {
    std::error_code ec;
    fs::create_directories(out_ / c.name, ec);
    if (ec) throw std::runtime_error((out_ / c.name).string() + ": cannot create (" + ec.message() + ")");
  }
}

namespace {

void write_png(const fs::path& p, const cv::Mat& img) {
  cv::Mat out = img;
  if (img.channels() == 3) cv::cvtColor(img, out, cv::COLOR_RGB2BGR);
  if (!cv::imwrite(p.string(), out)) throw std::runtime_error(p.string() + ": cannot write");
}

}  // namespace

bool CaptureRecorder::add(const std::string& name, const std::vector<cv::Mat>& images, bool floor) {
  ++offered_;
  std::vector<Detection> det(cams_.size());
  last_seen_.clear();
  for (size_t c = 0; c < cams_.size() && c < images.size(); ++c) {
    if (images[c].empty()) continue;
    det[c] = detect_board(images[c], board_);
    if (static_cast<int>(det[c].ids.size()) >= opt_.min_corners) last_seen_.push_back(static_cast<int>(c));
  }
  // A held set is kept when two or more cameras see the board well (solve chains cameras through shared
  // views); the floor view when any camera does (it sets the world frame).
  const bool keep = floor ? !last_seen_.empty() : last_seen_.size() >= 2;
  if (!keep) return false;
  ++kept_;
  for (size_t c = 0; c < cams_.size() && c < images.size(); ++c)
    if (!images[c].empty()) write_png(out_ / cams_[c].name / (name + ".png"), images[c]);
  const int n = opt_.cells;
  for (int c : last_seen_) {
    const auto cu = static_cast<size_t>(c);
    if (floor)
      ++floor_views_;
    else
      ++views_[cu];
    const CaptureCamera& cam = cams_[cu];
    for (const cv::Point2d& p : det[cu].image_px) {
      const int gx = std::clamp(static_cast<int>(p.x * n / std::max(cam.width, 1)), 0, n - 1);
      const int gy = std::clamp(static_cast<int>(p.y * n / std::max(cam.height, 1)), 0, n - 1);
      cover_[cu][static_cast<size_t>(gy) * static_cast<size_t>(n) + static_cast<size_t>(gx)] = true;
    }
  }
  return true;
}

std::string CaptureRecorder::views_line() const {
  std::string line = "views:";
  for (int v : views_) line += fmt::format(" {}", v);
  return line;
}

std::vector<std::string> CaptureRecorder::missing() const {
  std::vector<std::string> out;
  const SolveOptions so;
  const int cells = opt_.cells * opt_.cells;
  for (size_t c = 0; c < cams_.size(); ++c) {
    const int covered = static_cast<int>(std::count(cover_[c].begin(), cover_[c].end(), true));
    if (views_[c] < so.warn_views)
      out.push_back(fmt::format("{} needs {} more views", cams_[c].name, so.warn_views - views_[c]));
    if (covered < cells / 2)
      out.push_back(fmt::format("{} needs the board nearer its image edges", cams_[c].name));
  }
  if (floor_views_ == 0) out.emplace_back("a view of the board lying on the floor (the 'floor' set)");
  return out;
}

std::string CaptureRecorder::summary() const {
  const int n = opt_.cells;
  std::string s = fmt::format("coverage ({}x{} cells per image, # = board corners seen there):\n", n, n);
  for (int row = 0; row < n; ++row) {
    std::string line;
    for (size_t c = 0; c < cams_.size(); ++c) {
      line += "  ";
      for (int col = 0; col < n; ++col)
        line += cover_[c][static_cast<size_t>(row) * static_cast<size_t>(n) + static_cast<size_t>(col)] ? '#'
                                                                                                        : '.';
      line += "  ";
    }
    s += line + "\n";
  }
  for (size_t c = 0; c < cams_.size(); ++c) {
    const int covered = static_cast<int>(std::count(cover_[c].begin(), cover_[c].end(), true));
    s += fmt::format("{}: {} views, {} of {} cells\n", cams_[c].name, views_[c], covered, n * n);
  }
  const std::vector<std::string> miss = missing();
  if (miss.empty()) {
    s += fmt::format("nothing missing: run voxcap calibrate solve --images {} -o rig.yaml\n", out_.string());
  } else {
    for (const std::string& m : miss) s += "still missing: " + m + "\n";
  }
  return s;
}

}  // namespace vc::calibrate
