// The "file" camera backend: replays the image folders `voxcap sim --out DIR` writes —
// DIR/cam<k>/<frame>.png, or DIR/background/cam<k>/<i>.png with `background` — through the C
// vc_camera_backend interface. A C++17 shim because cv::imread is the PNG reader (BGR → RGB here).
//
// Frames are ordered by the number in their file name (zero padding or not). Which frame is shown
// when, free-running or triggered, is EmulatedTiming's (60 Hz unless fps is set). At the end of the
// sequence: wrap around with the option loop=1, else -ENODATA. Options (vc_camera_config::options):
// pace, loop, scene=empty (the background folder), seq_base. vc_camera_rewind switches between the
// two folders; the background then loops.
#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <opencv2/core.hpp>
#if VC_HAVE_IMGCODECS
#include <opencv2/imgcodecs.hpp>
#endif
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "emulated_timing.hpp"
#include "voxcap/edge/camera_backend.h"

namespace vc::edgecam {
namespace {

struct FileCamera {
  std::string dir;  // the `voxcap sim --out` folder
  int index = 0;
  std::string folder;
  std::vector<std::pair<uint64_t, std::string>> frames;  // (number in the name, path), sorted
  int width = 0, height = 0;
  bool loop = false, loop_live = false, triggered = false;
  EmulatedOptions opt;
  EmulatedTiming timing;
};

bool is_dir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// Frames of a folder: files named <digits>.png, by number.
std::vector<std::pair<uint64_t, std::string>> list_frames(const std::string& folder) {
  std::vector<std::pair<uint64_t, std::string>> out;
  DIR* d = opendir(folder.c_str());
  if (!d) return out;
  while (dirent* e = readdir(d)) {
    std::string name = e->d_name;
    if (name.size() < 5 || name.compare(name.size() - 4, 4, ".png") != 0) continue;
    std::string stem = name.substr(0, name.size() - 4);
    if (stem.empty() || stem.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string path = folder;
    path.append("/").append(name);
    out.emplace_back(std::strtoull(stem.c_str(), nullptr, 10), std::move(path));
  }
  closedir(d);
  std::sort(out.begin(), out.end());
  return out;
}

// cv::imread, or nothing in a build without OpenCV's imgcodecs (the arm64 cross build: Debian's arm64
// imgcodecs cannot be installed beside the amd64 host's libraries; a board's native build has it).
cv::Mat imread_bgr(const std::string& path) {
#if VC_HAVE_IMGCODECS
  return cv::imread(path, cv::IMREAD_COLOR);
#else
  (void)path;
  return {};
#endif
}
constexpr const char* kNoPng = VC_HAVE_IMGCODECS ? "" : " (PNG reading not built in: no OpenCV imgcodecs)";

// Reads a PNG into rgb (w x h, stride bytes per row). 0, -EIO (unreadable) or -ENOTSUP (size).
int read_rgb(vc_camera* cam, const std::string& path, int w, int h, uint8_t* rgb, size_t stride) {
  cv::Mat bgr = imread_bgr(path);
  if (bgr.empty()) return vc_camera_set_error(cam, -EIO, "cannot read image %s%s", path.c_str(), kNoPng);
  if (bgr.cols != w || bgr.rows != h)
    return vc_camera_set_error(cam, -EIO, "%s is %dx%d, the sequence is %dx%d", path.c_str(), bgr.cols,
                               bgr.rows, w, h);
  cv::Mat out(h, w, CV_8UC3, rgb, stride);
  cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
  return 0;
}

// The frames of one scene's folder into f (folder, frames) and the first image's size.
int load_scene(vc_camera* cam, FileCamera* f, vc_camera_scene scene, int* width, int* height) {
  std::string folder =
      f->dir + (scene == VC_CAMERA_SCENE_EMPTY ? "/background" : "") + "/cam" + std::to_string(f->index);
  if (!is_dir(folder))
    return vc_camera_set_error(cam, -ENOENT, "no folder %s (is this a `voxcap sim --out` folder?)",
                               folder.c_str());
  auto frames = list_frames(folder);
  if (frames.empty())
    return vc_camera_set_error(cam, -ENOENT, "no <number>.png frames in %s", folder.c_str());
  cv::Mat first = imread_bgr(frames[0].second);
  if (first.empty())
    return vc_camera_set_error(cam, -EIO, "cannot read image %s%s", frames[0].second.c_str(), kNoPng);
  *width = first.cols;
  *height = first.rows;
  f->folder = std::move(folder);
  f->frames = std::move(frames);
  return 0;
}

int file_open(vc_camera* cam, const vc_camera_config* cfg, vc_camera_info* info, void** out) {
  *out = nullptr;
  if (!cfg->device || !cfg->device[0])
    return vc_camera_set_error(cam, -EINVAL, "no folder given (the --out folder of `voxcap sim`)");
  std::string dir = cfg->device;
  if (!is_dir(dir)) return vc_camera_set_error(cam, -ENOENT, "no such folder");
  auto f = std::make_unique<FileCamera>();
  std::string why = f->opt.parse(cfg->options, true);
  if (!why.empty()) return vc_camera_set_error(cam, -EINVAL, "%s", why.c_str());
  f->dir = dir;
  f->index = cfg->index;
  int rc = load_scene(cam, f.get(), f->opt.scene, &f->width, &f->height);
  if (rc) return rc;
  if (cfg->width > 0 && (cfg->width != f->width || cfg->height != f->height))
    return vc_camera_set_error(cam, -ENOTSUP, "size %dx%d not supported (the images are %dx%d)", cfg->width,
                               cfg->height, f->width, f->height);
  if (cfg->n_controls)
    return vc_camera_set_error(cam, -ENOTSUP, "device controls are a v4l2 backend feature");
  const uint32_t fps_num = cfg->fps_num ? cfg->fps_num : 60,
                 fps_den = cfg->fps_num && cfg->fps_den ? cfg->fps_den : 1;
  f->timing.configure(*cfg, f->opt, 1000000000ull / 60);
  f->loop = f->loop_live = f->opt.loop;
  f->triggered = cfg->external_trigger;
  info->width = f->width;
  info->height = f->height;
  info->pixfmt = VC_PIXFMT_RGB24;
  info->fps_num = fps_num;
  info->fps_den = fps_den;
  info->buffers = 1;
  snprintf(info->driver, sizeof info->driver, "%zu frames", f->frames.size());
  *out = f.release();
  return 0;
}

int file_start(vc_camera*, void* p) {
  static_cast<FileCamera*>(p)->timing.start();
  return 0;
}

int file_stop(vc_camera*, void*) {
  return 0;
}

// Which frame ordinal `index` shows, honouring loop; false at the end of a non-looping sequence.
bool frame_at(const FileCamera* f, uint64_t index, size_t* ordinal) {
  if (index >= f->frames.size() && !f->loop) return false;
  *ordinal = (size_t)(index % f->frames.size());
  return true;
}

int file_capture(vc_camera* cam, void* p, int timeout_ms, uint8_t* rgb, size_t stride, vc_frame* meta) {
  auto* f = static_cast<FileCamera*>(p);
  EmulatedTiming::Shot shot;
  int rc = f->timing.next(cam, timeout_ms, &shot);
  if (rc) return rc;
  size_t ordinal;
  if (!frame_at(f, shot.index, &ordinal))
    return vc_camera_set_error(cam, -ENODATA, "end of the sequence (%zu frames, asked for frame %llu)",
                               f->frames.size(), (unsigned long long)shot.index);
  rc = read_rgb(cam, f->frames[ordinal].second, f->width, f->height, rgb, stride);
  if (rc) return rc;
  f->timing.delivered();
  meta->t_ns = shot.t_ns;
  meta->sequence = shot.sequence;
  meta->index = f->frames[ordinal].first;
  meta->flags = VC_FRAME_TS_SYNTH;
  return 0;
}

int file_soft_trigger(vc_camera* cam, void* p, uint64_t seq, uint64_t t_ns) {
  return static_cast<FileCamera*>(p)->timing.soft_trigger(cam, seq, t_ns);
}

uint32_t file_caps(const void* p) {
  auto* f = static_cast<const FileCamera*>(p);
  return f->opt.caps(f->triggered);
}

int file_rewind(vc_camera* cam, void* p, uint64_t seq_base, vc_camera_scene scene) {
  auto* f = static_cast<FileCamera*>(p);
  int w = 0, h = 0;
  int rc = load_scene(cam, f, scene, &w, &h);
  if (rc) return rc;
  if (w != f->width || h != f->height)
    return vc_camera_set_error(cam, -EIO, "the images of %s are %dx%d, the camera's %dx%d", f->folder.c_str(),
                               w, h, f->width, f->height);
  f->loop = scene == VC_CAMERA_SCENE_EMPTY ? true : f->loop_live;
  f->timing.rewind(seq_base);
  return 0;
}

void file_free(void* p) {
  delete static_cast<FileCamera*>(p);
}

}  // namespace
}  // namespace vc::edgecam

extern "C" const vc_camera_backend vc_camera_backend_file = {
    "file",
    vc::edgecam::file_open,
    vc::edgecam::file_start,
    vc::edgecam::file_capture,
    vc::edgecam::file_stop,
    vc::edgecam::file_free,
    vc::edgecam::file_soft_trigger,
    vc::edgecam::file_caps,
    vc::edgecam::file_rewind,
};
