// When an emulated camera (file, sim) exposes which frame, and with what timestamp. Internal to
// edge/camera.
//
//   free-running: frame n is stamped t0 + n·period (t0 = start time); with `pace` the capture sleeps
//     until that time, like a camera would, and times out when it is further away than the timeout;
//   external_trigger: the emulated twin of a triggered sensor — each soft_trigger(seq, t) exposes
//     frame seq − seq_base, stamped t + latency. soft_trigger may come from another thread than the
//     capture (the trigger input's); pending triggers are bounded (64), the oldest is dropped like a
//     sensor whose buffers are full, which shows as a gap in the frame sequence.
// rewind(seq_base) restarts the sequence (the camera is stopped): frame numbering, seq_base, triggers.
//
// The emulated cameras' own settings come from vc_camera_config::options ("key=value,..."), parsed
// here for both backends: pace, loop, scene=live|empty, seq_base.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <utility>

#include "voxcap/edge/camera_backend.h"

namespace vc::edgecam {

struct EmulatedOptions {
  bool pace = false;                             // free-running: deliver in real time at the frame rate
  bool loop = false;                             // file: wrap around at the end of the (live) sequence
  vc_camera_scene scene = VC_CAMERA_SCENE_LIVE;  // what it shows (empty: file's background folder)
  uint64_t seq_base = 0;                         // triggered: the frame for pulse seq is seq − seq_base

  // Parses "key=value,..." (NULL or "" = defaults). Returns "" or what is wrong; `loop_key`: whether
  // the backend takes loop.
  std::string parse(const char* options, bool loop_key);
  uint32_t caps(bool triggered) const;
};

class EmulatedTiming {
 public:
  struct Shot {
    uint64_t index;     // image to show
    uint64_t t_ns;      // CLOCK_MONOTONIC stamp
    uint64_t sequence;  // frames exposed so far (the "driver" counter)
  };

  void configure(const vc_camera_config& cfg, const EmulatedOptions& opt, uint64_t default_period_ns);
  // The camera is stopped: the next start exposes from frame 0 (free-running) or seq − seq_base.
  void rewind(uint64_t seq_base);
  uint64_t period_ns() const { return period_ns_; }
  bool triggered() const { return triggered_; }

  void start();
  // Blocks until the next frame is due (or a trigger came). 0, -ETIMEDOUT or -EINVAL (reported on cam).
  int next(vc_camera* cam, int timeout_ms, Shot* shot);
  // After the frame was delivered (free-running: advances to the next frame).
  void delivered();
  int soft_trigger(vc_camera* cam, uint64_t seq, uint64_t t_ns);

 private:
  static constexpr size_t kMaxPending = 64;
  uint64_t period_ns_ = 0;
  bool triggered_ = false, pace_ = false;
  int64_t latency_ns_ = 0;
  uint64_t seq_base_ = 0;
  uint64_t t0_ = 0;
  uint64_t next_ = 0;  // free-running: next frame ordinal
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::pair<uint64_t, uint64_t>> triggers_;  // (seq, t_ns)
  uint64_t sequence_ = 0;                               // under mu_
};

}  // namespace vc::edgecam
