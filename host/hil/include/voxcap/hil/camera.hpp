// The alignment test's cameras, behind one small interface: externally triggered, each frame's driver
// sequence and timestamp. The backend is chosen at link time (never by #ifdef): in a build with the
// edge part, edge/camera's vc_camera (v4l2, libcamera, file, sim: camera_edge.cpp); in a host-only
// build, which has no libcamera and so no camera library, camera_absent.cpp, whose open_camera()
// throws CamerasUnavailable with the reason and cameras_built_in() is false.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace vc::hil {

struct FrameStamp;

// One camera as the alignment test opens it.
struct CameraSpec {
  std::string backend;             // v4l2 | libcamera | file | sim
  std::string device;              // the backend's device (a sim scene spec for the emulated twin)
  std::string options;             // the backend's own "key=value,..." options
  std::string format = "default";  // v4l2 pixel format name
  int index = 0;                   // the camera's number (sim: which virtual camera)
  int width = 0, height = 0;       // 0: the backend's default
  int64_t exposure_us = 0;
  double latency_us = 0;  // frame timestamp − trigger edge, expected
  double rate_hz = 60;    // the trigger rate the sensor is told
};

// The camera path is not in this build (or not for this backend): the message says which build has it.
struct CamerasUnavailable : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A spec that cannot be opened as written (an unknown pixel format): bad input, not a device failure.
struct CameraSpecError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

class TriggeredCamera {
 public:
  virtual ~TriggeredCamera() = default;
  virtual void start() = 0;  // throws std::runtime_error with the backend's reason
  // Waits up to timeout_ms for a frame: 1 with *frame filled (its camera field left as is), 0 on a
  // timeout, -1 on an error (last_error()).
  virtual int capture(int timeout_ms, FrameStamp* frame) = 0;
  // Exposes a frame for pulse seq at t_ns: cameras that only expose when told (sim, file).
  virtual void soft_trigger(uint64_t seq, int64_t t_ns) = 0;
  virtual uint64_t driver_dropped() const = 0;
  virtual std::string last_error() const = 0;
};

// Whether this build has a camera backend at all.
bool cameras_built_in();
// Opens and configures one externally triggered camera. Throws CamerasUnavailable (no camera path in
// this build), CameraSpecError (bad spec) or std::runtime_error (the device did not open).
std::unique_ptr<TriggeredCamera> open_camera(const CameraSpec& spec);

}  // namespace vc::hil
