// The "sim" camera backend: the virtual rig (hw/sim) rendered in-process behind the C
// vc_camera_backend interface — the emulated rig's default camera.
//
// The scene is either borrowed (vc_camera_open_sim: a vc::sim::Scene* the caller shares, e.g. with
// its reference renders) or built from the device string, a spec of key=value pairs separated by ',' or ';':
//   motion=walk  seed=1  noise=2  flicker=0  appearance=default  room=default  fps=60  cameras=6 size=640x480
//   distortion=0  calibration=/path/rig.yaml  (a calibration replaces cameras/size/distortion)
//   bvh_scale=0  (metres per unit of a BVH motion; 0: detected, hw/body/README.md)
// Scenes built from the same spec are shared process-wide (one per spec, kept until the process
// ends), so a node's two cameras render one performer, and a camera reopened finds its per-camera
// render caches built (~0.3 s each at 640x480; sim_open builds them). cfg->index picks the scene
// camera. Frame timing is EmulatedTiming's at the scene's frame rate: free-running frame n, or the
// frame of pulse seq when triggered, so the image a pulse shows is the simulator's frame
// (seq − seq_base) — what the ground truth is indexed by. The empty scene (option scene=empty, or
// vc_camera_rewind, which the edge daemon calls at every phase) renders the empty room (frame i = the
// i-th noise draw). Options (vc_camera_config::options): pace, scene, seq_base.
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <sstream>
#include <stdexcept>
#include <string>

#include "emulated_timing.hpp"
#include "voxcap/edge/camera_backend.h"
#include "voxcap/edge/camera_sim.h"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/sim/scene.hpp"

namespace vc::edgecam {
namespace {

// Parses the spec into scene options. Returns an empty string or what is wrong.
std::string parse_spec(const std::string& spec, const vc_camera_config& cfg, sim::SceneOptions* o) {
  if (cfg.fps_num) o->motion.fps = (double)cfg.fps_num / (cfg.fps_den ? cfg.fps_den : 1);
  std::string item;
  std::string norm = spec;
  for (char& ch : norm)
    if (ch == ';') ch = ',';
  std::stringstream ss(norm);
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    size_t eq = item.find('=');
    if (eq == std::string::npos) return "'" + item + "' is not key=value";
    std::string key = item.substr(0, eq), val = item.substr(eq + 1);
    char* end = nullptr;
    auto number = [&](double* out) {
      *out = std::strtod(val.c_str(), &end);
      return !val.empty() && end && *end == '\0';
    };
    double v = 0;
    if (key == "motion") {
      o->motion.source = val;
    } else if (key == "appearance") {
      o->appearance = val;
    } else if (key == "room") {
      o->room = val;
    } else if (key == "calibration") {
      try {
        o->calibration = rig::read_calibration(val);
      } catch (const std::exception& e) {
        return std::string("calibration: ") + e.what();
      }
    } else if (key == "size") {
      int w = 0, h = 0;
      if (std::sscanf(val.c_str(), "%dx%d", &w, &h) != 2 || w <= 0 || h <= 0) return "size must be WxH";
      o->rig.width = w;
      o->rig.height = h;
    } else if (!number(&v)) {
      return "unknown key or bad value '" + item +
             "' (keys: motion, seed, noise, flicker, appearance, room, fps, cameras, size, "
             "distortion, calibration, bvh_scale)";
    } else if (key == "seed") {
      o->seed = (uint64_t)v;
    } else if (key == "noise") {
      o->noise_sigma = v;
    } else if (key == "flicker") {
      o->flicker = v;
    } else if (key == "fps") {
      o->motion.fps = v;
    } else if (key == "cameras") {
      o->rig.cameras = (int)v;
    } else if (key == "distortion") {
      o->rig.distortion = v != 0;
    } else if (key == "bvh_scale") {
      o->motion.bvh_scale = v;
    } else {
      return "unknown key '" + key +
             "' (keys: motion, seed, noise, flicker, appearance, room, fps, cameras, size, "
             "distortion, calibration, bvh_scale)";
    }
  }
  // the scene's cameras must match a size the caller asked for (the calibration's, if one is given)
  if (cfg.width > 0 && !o->calibration && spec.find("size=") == std::string::npos) {
    o->rig.width = cfg.width;
    o->rig.height = cfg.height;
  }
  std::string why;
  if (!o->valid(&why)) return why;
  return "";
}

// One scene per spec, shared by the cameras that name it and kept for the process's life.
std::shared_ptr<const sim::Scene> shared_scene(const std::string& key, const sim::SceneOptions& o) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<const sim::Scene>> scenes;
  std::lock_guard<std::mutex> lock(mu);
  std::shared_ptr<const sim::Scene>& s = scenes[key];
  if (!s) s = std::make_shared<const sim::Scene>(o);  // may throw: reported by the caller
  return s;
}

struct SimCamera {
  std::shared_ptr<const sim::Scene> owned;  // when built from the spec
  const sim::Scene* scene = nullptr;
  int cam = 0;
  bool background = false;
  bool triggered = false;
  EmulatedOptions opt;
  int width = 0, height = 0;
  EmulatedTiming timing;
  cv::Mat scratch;
};

int sim_open(vc_camera* cam, const vc_camera_config* cfg, vc_camera_info* info, void** out) {
  *out = nullptr;
  auto s = std::make_unique<SimCamera>();
  std::string bad = s->opt.parse(cfg->options, false);
  if (!bad.empty()) return vc_camera_set_error(cam, -EINVAL, "%s", bad.c_str());
  if (const void* borrowed = vc_camera_backend_arg(cam)) {
    s->scene = static_cast<const sim::Scene*>(borrowed);
  } else {
    sim::SceneOptions o;
    std::string spec = cfg->device ? cfg->device : "";
    std::string why = parse_spec(spec, *cfg, &o);
    if (!why.empty()) return vc_camera_set_error(cam, -EINVAL, "scene spec: %s", why.c_str());
    try {
      // fps and the requested size shape the scene too: they are part of its identity
      std::string key = spec + "|fps=" + std::to_string(o.motion.fps) + "|" + std::to_string(o.rig.width) +
                        "x" + std::to_string(o.rig.height);
      s->owned = shared_scene(key, o);
    } catch (const std::exception& e) {
      return vc_camera_set_error(cam, -EINVAL, "cannot build the scene: %s", e.what());
    }
    s->scene = s->owned.get();
  }
  const rig::Calibration& calib = s->scene->calibration();
  if (cfg->index >= s->scene->camera_count())
    return vc_camera_set_error(cam, -ENOENT, "no camera %d in the scene (it has %d)", cfg->index,
                               s->scene->camera_count());
  s->cam = cfg->index;
  s->width = calib.cameras[(size_t)s->cam].width;
  s->height = calib.cameras[(size_t)s->cam].height;
  if (cfg->width > 0 && (cfg->width != s->width || cfg->height != s->height))
    return vc_camera_set_error(cam, -ENOTSUP, "size %dx%d not supported (scene camera %d is %dx%d)",
                               cfg->width, cfg->height, s->cam, s->width, s->height);
  const double fps = s->scene->fps();
  if (cfg->fps_num && std::abs((double)cfg->fps_num / (cfg->fps_den ? cfg->fps_den : 1) - fps) > 1e-6)
    return vc_camera_set_error(cam, -ENOTSUP, "frame rate %u/%u does not match the scene's %g fps",
                               cfg->fps_num, cfg->fps_den ? cfg->fps_den : 1, fps);
  if (cfg->n_controls)
    return vc_camera_set_error(cam, -ENOTSUP, "device controls are a v4l2 backend feature");
  vc_camera_config timing_cfg = *cfg;
  timing_cfg.fps_num = 0;  // the scene's rate
  s->timing.configure(timing_cfg, s->opt, (uint64_t)(1e9 / fps + 0.5));
  s->background = s->opt.scene == VC_CAMERA_SCENE_EMPTY;
  s->triggered = cfg->external_trigger;
  // Build this camera's render caches now (once per process: the scene is kept), so that the first
  // exposures after a start are not spent on them.
  try {
    s->scene->render_background_clean(s->cam, s->scratch);
  } catch (const std::exception& e) {
    return vc_camera_set_error(cam, -EIO, "cannot prepare scene camera %d: %s", s->cam, e.what());
  }
  info->width = s->width;
  info->height = s->height;
  info->pixfmt = VC_PIXFMT_RGB24;
  info->fps_num = (uint32_t)(fps * 1000 + 0.5);
  info->fps_den = 1000;
  info->buffers = 1;
  snprintf(info->driver, sizeof info->driver, "sim %.40s cam %d/%d",
           s->scene->options().motion.source.c_str(), s->cam, s->scene->camera_count());
  *out = s.release();
  return 0;
}

int sim_start(vc_camera*, void* p) {
  static_cast<SimCamera*>(p)->timing.start();
  return 0;
}

int sim_stop(vc_camera*, void*) {
  return 0;
}

int sim_capture(vc_camera* cam, void* p, int timeout_ms, uint8_t* rgb, size_t stride, vc_frame* meta) {
  auto* s = static_cast<SimCamera*>(p);
  EmulatedTiming::Shot shot;
  int rc = s->timing.next(cam, timeout_ms, &shot);
  if (rc) return rc;
  if (shot.index > (uint64_t)INT32_MAX)
    return vc_camera_set_error(cam, -ENODATA, "frame %llu is beyond the simulator's range",
                               (unsigned long long)shot.index);
  try {
    if (s->background)
      s->scene->render_background(s->cam, (int)shot.index, s->scratch);
    else
      s->scene->render((int)shot.index, s->cam, s->scratch);
  } catch (const std::exception& e) {
    return vc_camera_set_error(cam, -EIO, "render of frame %llu failed: %s", (unsigned long long)shot.index,
                               e.what());
  }
  if (s->scratch.type() != CV_8UC3 || s->scratch.cols != s->width || s->scratch.rows != s->height)
    return vc_camera_set_error(cam, -EIO, "renderer returned a %dx%d image of type %d", s->scratch.cols,
                               s->scratch.rows, s->scratch.type());
  for (int y = 0; y < s->height; y++)
    std::memcpy(rgb + (size_t)y * stride, s->scratch.ptr(y), (size_t)s->width * 3);
  s->timing.delivered();
  meta->t_ns = shot.t_ns;
  meta->sequence = shot.sequence;
  meta->index = shot.index;
  meta->flags = VC_FRAME_TS_SYNTH;
  return 0;
}

int sim_soft_trigger(vc_camera* cam, void* p, uint64_t seq, uint64_t t_ns) {
  return static_cast<SimCamera*>(p)->timing.soft_trigger(cam, seq, t_ns);
}

uint32_t sim_caps(const void* p) {
  auto* s = static_cast<const SimCamera*>(p);
  return s->opt.caps(s->triggered);
}

int sim_rewind(vc_camera*, void* p, uint64_t seq_base, vc_camera_scene scene) {
  auto* s = static_cast<SimCamera*>(p);
  s->background = scene == VC_CAMERA_SCENE_EMPTY;
  s->timing.rewind(seq_base);
  return 0;
}

void sim_free(void* p) {
  delete static_cast<SimCamera*>(p);
}

}  // namespace
}  // namespace vc::edgecam

extern "C" const vc_camera_backend vc_camera_backend_sim = {
    "sim",
    vc::edgecam::sim_open,
    vc::edgecam::sim_start,
    vc::edgecam::sim_capture,
    vc::edgecam::sim_stop,
    vc::edgecam::sim_free,
    vc::edgecam::sim_soft_trigger,
    vc::edgecam::sim_caps,
    vc::edgecam::sim_rewind,
};

extern "C" int vc_camera_open_sim(const vc_camera_config* cfg, const void* scene, vc_camera** out, char* why,
                                  size_t why_len) {
  return vc_camera_open_backend_arg(&vc_camera_backend_sim, cfg, scene, out, why, why_len);
}
