// Where VMC bundles go: one bundle per sent frame (what it says: VmcPacket), behind a small interface
// with its two backends — liblo over UDP (the real one, make_liblo_sink) and an in-memory twin for tests.
//
// A bundle holds, in this order (protocol.vmc.info, "Marionette" spec):
//   /VMC/Ext/Root/Pos  "root" p.x p.y p.z q.x q.y q.z q.w     (with a pose)
//   /VMC/Ext/Bone/Pos  <HumanBodyBones name> p.x .. q.w       (with a pose: all kVmcBoneCount bones)
//   /VMC/Ext/OK        loaded calibration_state calibration_mode tracking   (ints; the V2.7 form)
//   /VMC/Ext/T         time                                   (float, seconds)
// OK and T last: receivers that apply a frame when they see them (VMC4UE) then have its bones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "voxcap/config/options.hpp"
#include "voxcap/stream/vmc_pose.hpp"

namespace vc::stream {

struct VmcPacket {
  double time_s = 0;  // /VMC/Ext/T: seconds since the stream's first frame, on the rig's clock
  int loaded = 0;     // 1 once bones are being sent
  int calibration_state =
      0;  // 0 uncalibrated, 1 waiting for calibration (the fitter initializing), 3 calibrated
  int calibration_mode = 0;  // 0: normal
  int tracking = 0;          // 1: this frame's pose was fitted; 0: predicted, held or none
  bool has_pose = false;     // Root and bones below are sent
  VmcPose pose;
};

class VmcSink {
 public:
  virtual ~VmcSink() = default;
  // Sends one bundle; never blocks. False, with why, when it was not sent (a full socket buffer, no
  // route): the caller counts it; the next bundle is tried as usual.
  virtual bool send(const VmcPacket& packet, std::string* why) = 0;
  virtual std::string target() const = 0;  // for messages: "127.0.0.1:39539"
};

// liblo (OSC over UDP) to `target`, from a socket of its own made non-blocking. "localhost" is sent to
// 127.0.0.1. Throws std::runtime_error when the socket or the address cannot be made.
std::unique_ptr<VmcSink> make_liblo_sink(const config::Endpoint& target);

// The twin: keeps the packets it is given (at most `keep`; later ones are counted only), and fails on
// request. For tests of the stage without sockets.
class MemorySink : public VmcSink {
 public:
  explicit MemorySink(size_t keep = 100000) : keep_(keep) {}
  bool send(const VmcPacket& packet, std::string* why) override {
    ++calls;
    if (fail) {
      if (why) *why = "refused by the test";
      return false;
    }
    if (packets.size() < keep_) packets.push_back(packet);
    return true;
  }
  std::string target() const override { return "memory"; }

  bool fail = false;
  uint64_t calls = 0;
  std::vector<VmcPacket> packets;

 private:
  size_t keep_;
};

}  // namespace vc::stream
