// The alignment test's cameras over edge/camera's vc_camera: a build with the edge part.
#include <cerrno>
#include <cmath>

#include <fmt/core.h>

#include "voxcap/edge/camera.h"
#include "voxcap/hil/camera.hpp"
#include "voxcap/hil/measure.hpp"

namespace vc::hil {
namespace {

class EdgeCamera final : public TriggeredCamera {
 public:
  explicit EdgeCamera(const CameraSpec& spec) : spec_(spec) {
    vc_camera_config cfg;
    vc_camera_config_init(&cfg);
    cfg.external_trigger = true;
    cfg.fps_num = static_cast<uint32_t>(std::lround(spec_.rate_hz));
    cfg.fps_den = 1;
    cfg.index = spec_.index;
    cfg.width = spec_.width;
    cfg.height = spec_.height;
    cfg.exposure_us = spec_.exposure_us;
    if (spec_.backend == "v4l2" && vc_pixfmt_from_name(spec_.format.c_str(), &cfg.pixfmt) != 0)
      throw CameraSpecError(fmt::format("unknown pixel format \"{}\"", spec_.format));
    cfg.backend = spec_.backend.c_str();
    cfg.device = spec_.device.c_str();
    cfg.options = spec_.options.empty() ? nullptr : spec_.options.c_str();
    cfg.trigger_latency_ns = static_cast<int64_t>(spec_.latency_us * 1e3);
    char why[320] = "";
    if (vc_camera_open(&cfg, &cam_, why, sizeof why) != 0) throw std::runtime_error(why);
  }
  EdgeCamera(const EdgeCamera&) = delete;
  EdgeCamera& operator=(const EdgeCamera&) = delete;
  ~EdgeCamera() override { vc_camera_free(cam_); }

  void start() override {
    if (vc_camera_start(cam_) != 0) throw std::runtime_error(vc_camera_last_error(cam_));
  }
  int capture(int timeout_ms, FrameStamp* frame) override {
    vc_frame f;
    const int rc = vc_camera_capture(cam_, timeout_ms, &f);
    if (rc == -ETIMEDOUT) return 0;
    if (rc != 0) return -1;
    frame->sequence = f.sequence;
    frame->t_ns = static_cast<int64_t>(f.t_ns);
    vc_camera_release(cam_, &f);
    return 1;
  }
  void soft_trigger(uint64_t seq, int64_t t_ns) override {
    vc_camera_soft_trigger(cam_, seq, static_cast<uint64_t>(t_ns));
  }
  uint64_t driver_dropped() const override {
    vc_camera_stats st{};
    vc_camera_get_stats(cam_, &st);
    return st.dropped;
  }
  std::string last_error() const override { return vc_camera_last_error(cam_); }

 private:
  CameraSpec spec_;  // the config's strings point into it
  vc_camera* cam_ = nullptr;
};

}  // namespace

bool cameras_built_in() {
  return true;
}

std::unique_ptr<TriggeredCamera> open_camera(const CameraSpec& spec) {
  return std::make_unique<EdgeCamera>(spec);
}

}  // namespace vc::hil
