// Absolute pulse grid and the never-burst catch-up policy; see scheduler.hpp for the why.
#include "voxcap/trigger/scheduler.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace vc::trigger {
namespace {

constexpr uint64_t kNsPerSecondTimesMicro = 1'000'000'000'000'000ULL;  // 1e9 ns/s * 1e6 uHz/Hz

using u128 = unsigned __int128;

}  // namespace

bool ScheduleOptions::valid(std::string* why) const {
  auto fail = [why](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    return fail(fmt::format("rate_hz: must be in (0, 1000], got {}", rate_hz));
  if (std::llround(rate_hz * 1e6) < 1) return fail(fmt::format("rate_hz: below 1 uHz, got {}", rate_hz));
  if (late_threshold_ns < 0)
    return fail(fmt::format("late_threshold_ns: must be >= 0, got {}", late_threshold_ns));
  const double half_period_ns = 0.5e9 / rate_hz;
  if (max_lateness_ns != -1 && (max_lateness_ns < 0 || static_cast<double>(max_lateness_ns) > half_period_ns))
    return fail(fmt::format("max_lateness_ns: must be -1 (half a period) or in [0, {:.0f}], got {}",
                            half_period_ns, max_lateness_ns));
  return true;
}

PulseScheduler::PulseScheduler(const ScheduleOptions& options) : options_(options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("pulse scheduler: " + why);
  rate_uhz_ = static_cast<uint64_t>(std::llround(options.rate_hz * 1e6));
  period_ns_ = static_cast<int64_t>(kNsPerSecondTimesMicro / rate_uhz_);
  max_lateness_ns_ = options.max_lateness_ns == -1 ? period_ns_ / 2 : options.max_lateness_ns;
  next_seq_ = options.first_seq;
}

int64_t PulseScheduler::slot_time_ns(uint64_t slot) const {
  const u128 offset = static_cast<u128>(slot) * kNsPerSecondTimesMicro / rate_uhz_;
  return options_.start_ns + static_cast<int64_t>(offset);
}

uint64_t PulseScheduler::first_slot_at_or_after(int64_t t_ns, uint64_t from) const {
  uint64_t k = 0;
  if (t_ns > options_.start_ns) {
    const u128 since = static_cast<u128>(t_ns - options_.start_ns);
    k = static_cast<uint64_t>(since * rate_uhz_ / kNsPerSecondTimesMicro);
    // The closed form can be one slot off either way because slot times are floored.
    while (slot_time_ns(k) < t_ns) ++k;
    while (k > 0 && slot_time_ns(k - 1) >= t_ns) --k;
  }
  return k < from ? from : k;
}

std::optional<Due> PulseScheduler::take(int64_t now_ns) {
  if (done()) return std::nullopt;
  uint64_t slot = next_slot_;
  if (now_ns < slot_time_ns(slot)) return std::nullopt;

  int64_t lateness = now_ns - slot_time_ns(slot);
  uint64_t skipped = 0;
  if (lateness > max_lateness_ns_) {
    // Skip every slot more than max_lateness overdue; emit the first one that is not, if it is due.
    const uint64_t next = first_slot_at_or_after(now_ns - max_lateness_ns_, slot + 1);
    skipped = next - slot;
    stats_.missed += skipped;
    next_slot_ = slot = next;
    if (now_ns < slot_time_ns(slot)) return std::nullopt;
    lateness = now_ns - slot_time_ns(slot);
  }

  Due due;
  due.seq = next_seq_++;
  due.slot = slot;
  due.slot_ns = slot_time_ns(slot);
  due.lateness_ns = lateness;
  due.skipped = skipped;
  next_slot_ = slot + 1;
  ++stats_.emitted;
  if (lateness > options_.late_threshold_ns) ++stats_.late;
  if (lateness > stats_.max_lateness_ns) stats_.max_lateness_ns = lateness;
  return due;
}

}  // namespace vc::trigger
