// The pulse thread shared by all backends, and the host-timed loop of udp and gpiod.
#include "threaded_generator.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "voxcap/base/clock.hpp"
#include "voxcap/trigger/scheduler.hpp"

namespace vc::trigger {

bool PulseTrain::valid(std::string* why) const {
  auto fail = [why](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    return fail(fmt::format("rate: must be in (0, 1000] Hz, got {}", rate_hz));
  if (!(pulse_width_us > 0.0))
    return fail(fmt::format("pulse width: must be > 0 us, got {}", pulse_width_us));
  const double half_period_us = 0.5e6 / rate_hz;
  if (pulse_width_us >= half_period_us)
    return fail(fmt::format("pulse width: must be less than half the period ({:.6g} us at {} Hz), got {}",
                            half_period_us, rate_hz, pulse_width_us));
  return true;
}

PulseTrain PulseTrain::from(const config::TriggerOptions& options, uint64_t count) {
  return PulseTrain{options.rate_hz, options.pulse_width_us, count, 0};
}

namespace detail {
namespace {

// First pulse this long after start(): the thread is running and the device settled by then.
constexpr int64_t kStartLeadNs = 5'000'000;
// stop() is noticed within this long however slow the rate.
constexpr int64_t kSleepSliceNs = 20'000'000;

void sleep_abs(int64_t t_ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace

bool try_realtime(int priority) {
  // Normal threads have their timed sleeps stretched by up to 50 us of timer slack; the pulse thread
  // wants its wake-ups exact whatever its policy (real-time threads have no slack anyway).
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (priority <= 0) return false;
  sched_param param{};
  param.sched_priority = std::min(priority, sched_get_priority_max(SCHED_FIFO));
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  if (rc == 0) {
    spdlog::debug("trigger: pulse thread at SCHED_FIFO {}", param.sched_priority);
    return true;
  }
  static std::once_flag noted;
  std::call_once(noted, [&] {
    spdlog::info(
        "trigger: real-time priority SCHED_FIFO {} not permitted ({}); pulses are timed on a "
        "normal thread (grant CAP_SYS_NICE or an rtprio limit for tighter timing)",
        param.sched_priority, std::strerror(rc));
  });
  return false;
}

ThreadedGenerator::~ThreadedGenerator() {
  // Normally already stopped by the derived destructor; this only catches a forgotten one.
  stop_requested_ = true;
  if (thread_.joinable()) thread_.join();
}

void ThreadedGenerator::start(const PulseTrain& train) {
  std::string why;
  if (!train.valid(&why)) throw TriggerError(fmt::format("{}: {}", backend(), why));
  if (running_) throw TriggerError(fmt::format("{}: already running", backend()));
  if (thread_.joinable()) thread_.join();  // a previous train that ended by itself
  prepare(train);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_ = Stats{};
    last_error_.clear();
  }
  sent_ = 0;
  stop_requested_ = false;
  running_ = true;
  thread_ = std::thread(&ThreadedGenerator::thread_main, this, train);
}

void ThreadedGenerator::thread_main(PulseTrain train) {
  try_realtime(options_.rt_priority);
  std::string error;
  try {
    run(train);
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (!error.empty()) spdlog::error("trigger: {}", error);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = error;
    running_ = false;
  }
  done_.notify_all();
}

void ThreadedGenerator::stop() {
  stop_requested_ = true;
  if (thread_.joinable()) thread_.join();
}

bool ThreadedGenerator::wait_done(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return done_.wait_for(lock, timeout, [this] { return !running_.load(); });
}

Stats ThreadedGenerator::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Stats s = stats_;
  s.pulses_sent = sent_.load();
  return s;
}

std::string ThreadedGenerator::last_error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_error_;
}

void ThreadedGenerator::record_pulse(const Pulse& pulse) {
  sent_.fetch_add(1);
  if (observer_) observer_(pulse);
}

bool ScheduledGenerator::sleep_until(int64_t t_ns) const {
  for (;;) {
    if (stop_requested()) return false;
    const int64_t now = static_cast<int64_t>(vc::monotonic_ns());
    if (now >= t_ns) return true;
    sleep_abs(std::min(t_ns, now + kSleepSliceNs));
  }
}

void ScheduledGenerator::run(const PulseTrain& train) {
  ScheduleOptions so;
  so.start_ns = static_cast<int64_t>(vc::monotonic_ns()) + kStartLeadNs;
  so.rate_hz = train.rate_hz;
  so.first_seq = train.first_seq;
  so.count = train.count;
  so.late_threshold_ns = static_cast<int64_t>(options().late_threshold_us * 1e3);
  PulseScheduler scheduler(so);
  const int64_t width_ns = static_cast<int64_t>(train.pulse_width_us * 1e3);

  while (!scheduler.done()) {
    if (!sleep_until(scheduler.next_due_ns())) break;
    const std::optional<Due> due = scheduler.take(static_cast<int64_t>(vc::monotonic_ns()));
    update_stats([&](Stats& s) {
      const ScheduleStats& st = scheduler.stats();
      s.late = st.late;
      s.missed = st.missed;
      s.max_lateness_ns = st.max_lateness_ns;
    });
    if (!due) continue;  // every overdue slot was skipped; sleep until the next one
    Pulse pulse;
    pulse.seq = due->seq;
    pulse.lateness_ns = due->lateness_ns;
    leading_edge(pulse);
    if (has_width()) {
      // Absolute from the measured edge: the width holds even when the edge itself was late.
      sleep_abs(pulse.t_ns + width_ns);
      trailing_edge();
    }
    record_pulse(pulse);
  }
}

}  // namespace detail
}  // namespace vc::trigger
