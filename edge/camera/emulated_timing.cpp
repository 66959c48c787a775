// Frame timing of the emulated cameras; see emulated_timing.hpp.
#include "emulated_timing.hpp"

#include <time.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <sstream>

#include "voxcap/edge/clock.h"

namespace vc::edgecam {

std::string EmulatedOptions::parse(const char* options, bool loop_key) {
  const std::string keys = loop_key ? "pace, loop, scene, seq_base" : "pace, scene, seq_base";
  std::stringstream ss(options ? options : "");
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    size_t eq = item.find('=');
    if (eq == std::string::npos) return "option '" + item + "' is not key=value";
    std::string key = item.substr(0, eq), val = item.substr(eq + 1);
    auto flag = [&](bool* out) {
      if (val != "0" && val != "1") return false;
      *out = val == "1";
      return true;
    };
    if (key == "pace") {
      if (!flag(&pace)) return "option pace must be 0 or 1";
    } else if (key == "loop" && loop_key) {
      if (!flag(&loop)) return "option loop must be 0 or 1";
    } else if (key == "scene") {
      if (val == "live")
        scene = VC_CAMERA_SCENE_LIVE;
      else if (val == "empty")
        scene = VC_CAMERA_SCENE_EMPTY;
      else
        return "option scene must be live or empty";
    } else if (key == "seq_base") {
      char* end = nullptr;
      seq_base = std::strtoull(val.c_str(), &end, 10);
      if (val.empty() || val[0] == '-' || *end != '\0') return "option seq_base must be a number";
    } else {
      return "unknown option '" + key + "' (options: " + keys + ")";
    }
  }
  return "";
}

uint32_t EmulatedOptions::caps(bool triggered) const {
  return VC_CAMERA_CAP_REWIND | (triggered ? VC_CAMERA_CAP_SOFT_TRIGGER : 0u);
}

void EmulatedTiming::configure(const vc_camera_config& cfg, const EmulatedOptions& opt,
                               uint64_t default_period_ns) {
  period_ns_ =
      cfg.fps_num ? 1000000000ull * (cfg.fps_den ? cfg.fps_den : 1) / cfg.fps_num : default_period_ns;
  triggered_ = cfg.external_trigger;
  pace_ = opt.pace;
  latency_ns_ = cfg.trigger_latency_ns;
  seq_base_ = opt.seq_base;
}

void EmulatedTiming::rewind(uint64_t seq_base) {
  seq_base_ = seq_base;
  next_ = 0;
  std::lock_guard<std::mutex> lock(mu_);
  triggers_.clear();
  sequence_ = 0;
}

void EmulatedTiming::start() {
  t0_ = vc_clock_monotonic_ns();
  next_ = 0;
  std::lock_guard<std::mutex> lock(mu_);
  triggers_.clear();
}

int EmulatedTiming::next(vc_camera* cam, int timeout_ms, Shot* shot) {
  if (triggered_) {
    std::unique_lock<std::mutex> lock(mu_);
    auto ready = [&] { return !triggers_.empty(); };
    if (timeout_ms < 0)
      cv_.wait(lock, ready);
    else if (!cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), ready))
      return vc_camera_set_error(cam, -ETIMEDOUT, "camera stopped delivering: no trigger within %d ms",
                                 timeout_ms);
    auto [seq, t] = triggers_.front();
    triggers_.pop_front();
    shot->sequence = sequence_++;
    lock.unlock();
    if (seq < seq_base_)
      return vc_camera_set_error(cam, -EINVAL, "trigger seq %llu is below seq_base %llu",
                                 (unsigned long long)seq, (unsigned long long)seq_base_);
    shot->index = seq - seq_base_;
    shot->t_ns = (uint64_t)((int64_t)t + latency_ns_);
    return 0;
  }
  shot->index = next_;
  shot->sequence = next_;
  shot->t_ns = t0_ + next_ * period_ns_;
  if (pace_) {
    uint64_t now = vc_clock_monotonic_ns();
    if (shot->t_ns > now) {
      if (timeout_ms >= 0 && shot->t_ns - now > (uint64_t)timeout_ms * 1000000ull) {
        const struct timespec ts = vc_clock_timespec((uint64_t)timeout_ms * 1000000ull);
        nanosleep(&ts, nullptr);
        return vc_camera_set_error(cam, -ETIMEDOUT, "camera stopped delivering: no frame within %d ms",
                                   timeout_ms);
      }
      const struct timespec ts = vc_clock_timespec(shot->t_ns);  // an absolute MONOTONIC time
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
    }
  }
  return 0;
}

void EmulatedTiming::delivered() {
  if (!triggered_) next_++;
}

int EmulatedTiming::soft_trigger(vc_camera* cam, uint64_t seq, uint64_t t_ns) {
  if (!triggered_)
    return vc_camera_set_error(cam, -EINVAL, "soft trigger on a free-running camera (set external_trigger)");
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (triggers_.size() == kMaxPending) {
      triggers_.pop_front();
      sequence_++;
    }
    triggers_.emplace_back(seq, t_ns);
  }
  cv_.notify_one();
  return 0;
}

}  // namespace vc::edgecam
