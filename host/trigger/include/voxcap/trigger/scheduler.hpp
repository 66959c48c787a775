// The pulse scheduler: pure timing logic shared by the host-timed trigger backends (udp, gpiod).
//
// Pulse slots sit on an absolute grid t_k = start + floor(k * 1e15 / rate_uhz) ns, computed exactly in
// integers from the start time, so the train never drifts however long it runs and however late a
// wake-up was (a relative "sleep one period" loop would accumulate every delay). The thread sleeps
// with clock_nanosleep(TIMER_ABSTIME) until next_due_ns() and then asks take(now) what to emit.
//
// Catch-up policy when the thread wakes late: a slot is still emitted while it is less than
// max_lateness (half a period by default) overdue; slots further behind are skipped and counted as
// missed. At most one pulse is emitted per take(), so a stall never turns into a burst: with the
// default max_lateness any two emitted pulses are at least half a period apart, and with a pulse width
// below half a period (TriggerOptions::valid) pulses never merge. `seq` counts emitted pulses only: it
// stays consecutive across skipped slots, exactly as an edge counting rising edges on its GPIO input
// would count them, so seq means the same thing on every backend.
//
// Limits: the grid is in CLOCK_MONOTONIC nanoseconds; rates are held in micro-hertz (1e-6 Hz
// resolution), and the scheduler knows nothing about how long an emit takes (the caller measures).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace vc::trigger {

struct ScheduleOptions {
  int64_t start_ns = 0;                // CLOCK_MONOTONIC time of slot 0
  double rate_hz = 60.0;               // (0, 1000]
  uint64_t first_seq = 0;              // seq of the first emitted pulse
  uint64_t count = 0;                  // pulses to emit; 0 = unlimited
  int64_t late_threshold_ns = 500000;  // emitted later than this: counted as late
  int64_t max_lateness_ns = -1;        // later than this: slot skipped (missed); -1 = half a period

  bool valid(std::string* why) const;
};

// What take() decided to emit now.
struct Due {
  uint64_t seq = 0;         // pulse counter of this pulse
  uint64_t slot = 0;        // grid index k (>= the number of pulses emitted: slots can be skipped)
  int64_t slot_ns = 0;      // scheduled time t_k
  int64_t lateness_ns = 0;  // now - t_k, >= 0
  uint64_t skipped = 0;     // slots skipped (missed) just before this one
};

struct ScheduleStats {
  uint64_t emitted = 0;
  uint64_t late = 0;    // emitted with lateness > late_threshold_ns
  uint64_t missed = 0;  // slots skipped because they were more than max_lateness_ns overdue
  int64_t max_lateness_ns = 0;
};

class PulseScheduler {
 public:
  // Throws std::invalid_argument when options are not valid().
  explicit PulseScheduler(const ScheduleOptions& options);

  // Absolute time of the next slot still to be emitted (the time to sleep until).
  int64_t next_due_ns() const { return slot_time_ns(next_slot_); }
  // True once `count` pulses have been emitted (never for an unlimited train).
  bool done() const { return options_.count != 0 && stats_.emitted >= options_.count; }

  // Called after waking at `now_ns`. Returns the pulse to emit now, or nothing when the next slot is
  // still ahead (woke early, or every overdue slot was skipped and the next one lies in the future).
  std::optional<Due> take(int64_t now_ns);

  // t_k for slot k on the grid.
  int64_t slot_time_ns(uint64_t slot) const;
  int64_t period_ns() const { return period_ns_; }  // rounded; the grid itself is exact
  int64_t max_lateness_ns() const { return max_lateness_ns_; }
  const ScheduleStats& stats() const { return stats_; }

 private:
  // First slot >= `from` whose time is >= t (closed form plus a one-step correction).
  uint64_t first_slot_at_or_after(int64_t t_ns, uint64_t from) const;

  ScheduleOptions options_;
  uint64_t rate_uhz_ = 0;
  int64_t period_ns_ = 0;
  int64_t max_lateness_ns_ = 0;
  uint64_t next_slot_ = 0;
  uint64_t next_seq_ = 0;
  ScheduleStats stats_;
};

}  // namespace vc::trigger
