// VmcStage: the live pose stream out over the VMC protocol, a consumer of the host's pipeline
// (pipeline().tap(), drop-oldest: a live consumer never holds the rig back).
//
// Rate: `rate_hz` of [vmc], at most the rig's trigger rate. Frames are picked by their trigger seq, not
// by the wall clock: frame seq is sent when its slot floor(seq * rate / rig_rate) is past the last one
// sent (rate = rig rate: every frame; 30 of a 60 Hz rig: every other seq); a frame that reaches the
// stage after a later one (the assembler resolves frames as they complete) is not sent, so /VMC/Ext/T
// never goes back. Every picked frame sends one
// bundle (vmc_sink.hpp): before the fitter's first pose only OK (loaded 0, waiting for calibration) and
// T; with a pose its bones (vmc_pose.hpp) and OK (loaded 1, calibrated, tracking 1 when fitted, 0 when
// predicted); a frame without a pose after the first re-sends the last pose with tracking 0, as the
// take holds it.
//
// Never slows the rig: the socket is non-blocking (a full buffer is a send error, not a wait), a send
// error is counted and logged at most once a second with how many there were, a bad pose is counted and
// skipped, and configure() is the only place that may throw (a target liblo cannot address).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "voxcap/config/options.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/pipeline/stage.hpp"
#include "voxcap/stream/vmc_pose.hpp"
#include "voxcap/stream/vmc_sink.hpp"

namespace vc::stream {

struct VmcCounters {
  double rate_hz = 0;        // the rate in force (configured, capped at the rig's)
  uint64_t frames = 0;       // frames the stage saw
  uint64_t picked = 0;       // of those, picked by the rate
  uint64_t stale = 0;        // ... not picked: older than the last one picked (out of seq order)
  uint64_t sent = 0;         // bundles sent
  uint64_t with_pose = 0;    // ... of those with bones
  uint64_t held = 0;         // ... re-sending the last pose (the frame had none)
  uint64_t send_errors = 0;  // bundles the sink did not send
  uint64_t bad_poses = 0;    // poses that could not be converted (not finite): skipped, counted
  uint64_t rests_built = 0;  // rest skeletons (one per body version)
};

class VmcStage : public pipeline::Stage {
 public:
  static constexpr pipeline::QueueOptions kQueue{4, pipeline::Overflow::DropOldest};

  // `sink` null: liblo to options.target, made in configure().
  explicit VmcStage(config::VmcOptions options, std::unique_ptr<VmcSink> sink = nullptr);

  std::string name() const override { return "vmc"; }
  // Checks the options (std::invalid_argument naming the key), caps the rate at the rig's trigger rate,
  // makes the sink (std::runtime_error when liblo cannot).
  void configure(const pipeline::StageContext& ctx) override;
  void process(pipeline::Frame& frame) override;
  void stop() override;

  VmcCounters counters() const;  // thread-safe

 private:
  void note_error(const std::string& what, uint64_t now_ns);

  config::VmcOptions options_;
  std::unique_ptr<VmcSink> sink_;
  log::Fn log_;
  double rig_rate_hz_ = 0, rate_hz_ = 0;
  bool any_picked_ = false;
  int64_t last_slot_ = 0;
  bool have_t0_ = false;
  uint64_t t0_ns_ = 0;
  VmcPoser poser_;
  VmcPacket last_;  // the last packet with a pose (held frames re-send it)
  bool have_last_ = false;
  uint64_t last_log_ns_ = 0, unlogged_errors_ = 0;
  bool logged_once_ = false;
  mutable std::mutex mu_;
  VmcCounters c_;
};

}  // namespace vc::stream
