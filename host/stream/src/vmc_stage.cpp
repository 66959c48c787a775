// The VMC stage: picks frames by seq at the configured rate, turns their pose into bones and hands one
// bundle per picked frame to the sink. The rules are in vmc_stage.hpp.
#include "voxcap/stream/vmc_stage.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "voxcap/base/clock.hpp"
#include "voxcap/config/rig_config.hpp"

namespace vc::stream {

VmcStage::VmcStage(config::VmcOptions options, std::unique_ptr<VmcSink> sink)
    : options_(std::move(options)), sink_(std::move(sink)) {}

void VmcStage::configure(const pipeline::StageContext& ctx) {
  std::string why;
  if (!options_.valid(&why)) throw std::invalid_argument("vmc." + why);
  log_ = log::or_spdlog(ctx.log);
  rig_rate_hz_ = ctx.rig && ctx.rig->trigger.rate_hz > 0 ? ctx.rig->trigger.rate_hz : options_.rate_hz;
  rate_hz_ = std::min(options_.rate_hz, rig_rate_hz_);
  if (!sink_) sink_ = make_liblo_sink(options_.target);
  {
    std::lock_guard<std::mutex> g(mu_);
    c_.rate_hz = rate_hz_;
  }
  log_(log::Level::info,
       fmt::format("streaming the pose over VMC (OSC/UDP) to {} at {:g} Hz{}", sink_->target(), rate_hz_,
                   options_.rate_hz > rig_rate_hz_
                       ? fmt::format(" (rate_hz {:g} is above the rig's {:g} Hz: every frame)",
                                     options_.rate_hz, rig_rate_hz_)
                       : std::string()));
}

void VmcStage::note_error(const std::string& what, uint64_t now_ns) {
  ++unlogged_errors_;
  if (logged_once_ && now_ns - last_log_ns_ < 1'000'000'000ULL) return;
  log_(log::Level::warn, unlogged_errors_ == 1
                             ? fmt::format("to {}: {}", sink_->target(), what)
                             : fmt::format("to {}: {} problems since the last line; the last: {}",
                                           sink_->target(), unlogged_errors_, what));
  logged_once_ = true;
  last_log_ns_ = now_ns;
  unlogged_errors_ = 0;
}

void VmcStage::process(pipeline::Frame& f) {
  const auto slot = static_cast<int64_t>(std::floor(static_cast<double>(f.seq) * rate_hz_ / rig_rate_hz_));
  // Frames may leave the assembler out of seq order (a late one resolved after its successor): never
  // go back, so T only grows and no slot is sent twice.
  const bool stale = any_picked_ && slot < last_slot_;
  if (stale || (any_picked_ && slot == last_slot_)) {
    std::lock_guard<std::mutex> g(mu_);
    ++c_.frames;
    c_.stale += stale ? 1 : 0;
    return;
  }
  any_picked_ = true;
  last_slot_ = slot;
  if (!have_t0_) {
    t0_ns_ = f.t_trigger_ns;
    have_t0_ = true;
  }

  VmcPacket pk;
  pk.time_s = f.t_trigger_ns >= t0_ns_ ? static_cast<double>(f.t_trigger_ns - t0_ns_) * 1e-9 : 0.0;
  bool bad = false, held = false;
  std::string problem;
  if (f.pose.valid()) {
    try {
      pk.pose = poser_.pose(f.pose);
      pk.has_pose = true;
      pk.loaded = 1;
      pk.calibration_state = 3;
      pk.tracking = f.pose.state == pipeline::PoseState::Predicted ? 0 : 1;
      last_ = pk;
      have_last_ = true;
    } catch (const std::invalid_argument& e) {
      bad = true;
      problem = fmt::format("frame seq {}: {}", f.seq, e.what());
    }
  }
  if (!pk.has_pose && have_last_) {  // as the take holds it: the last pose, tracking lost
    pk.pose = last_.pose;
    pk.has_pose = true;
    pk.loaded = 1;
    pk.calibration_state = 3;
    pk.tracking = 0;
    held = true;
  } else if (!pk.has_pose) {
    pk.loaded = 0;
    pk.calibration_state = 1;  // the fitter is still initializing the body model
  }
  std::string why;
  const bool ok = sink_->send(pk, &why);
  {
    std::lock_guard<std::mutex> g(mu_);
    ++c_.frames;
    ++c_.picked;
    c_.sent += ok ? 1 : 0;
    c_.with_pose += ok && pk.has_pose ? 1 : 0;
    c_.held += ok && held ? 1 : 0;
    c_.send_errors += ok ? 0 : 1;
    c_.bad_poses += bad ? 1 : 0;
    c_.rests_built = poser_.rests_built();
  }
  if (bad || !ok) {
    const uint64_t now = monotonic_ns();
    if (bad) note_error(problem, now);
    if (!ok) note_error("bundle not sent: " + why, now);
  }
}

void VmcStage::stop() {
  const VmcCounters c = counters();
  if (unlogged_errors_ > 0 || c.send_errors > 0 || c.bad_poses > 0)
    log_(log::Level::warn,
         fmt::format("to {}: {} of {} bundles not sent, {} poses not convertible",
                     sink_ ? sink_->target() : options_.target.str(), c.send_errors, c.picked, c.bad_poses));
}

VmcCounters VmcStage::counters() const {
  std::lock_guard<std::mutex> g(mu_);
  return c_;
}

}  // namespace vc::stream
