// Internal: what every backend shares — the pulse thread, its real-time priority, stop/wait, the
// statistics and the error that stopped it — and the host-timed loop of the udp and gpiod backends.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "voxcap/config/options.hpp"
#include "voxcap/trigger/generator.hpp"

namespace vc::trigger::detail {

class ThreadedGenerator : public Generator {
 public:
  explicit ThreadedGenerator(config::TriggerOptions options) : options_(std::move(options)) {}
  // Derived destructors must call stop() first: the thread calls their virtual functions.
  ~ThreadedGenerator() override;

  using Generator::start;  // start(rate_hz, pulse_width_us) too
  void start(const PulseTrain& train) final;
  void stop() final;
  bool wait_done(std::chrono::milliseconds timeout) final;
  bool running() const final { return running_.load(); }
  uint64_t pulses_sent() const final { return sent_.load(); }
  Stats stats() const final;
  std::string last_error() const final;

 protected:
  // On the caller's thread before the pulse thread starts: open the device on first use, check the
  // train against the backend's limits. Throws TriggerError.
  virtual void prepare(const PulseTrain& train) = 0;
  // The pulse loop on the pulse thread. Returns when the train is complete or stop_requested();
  // throws TriggerError on a failure (which becomes last_error()).
  virtual void run(const PulseTrain& train) = 0;

  bool stop_requested() const { return stop_requested_.load(std::memory_order_relaxed); }
  // Counts the pulse and tells the observer.
  void record_pulse(const Pulse& pulse);
  // Backend-specific counters, under the stats lock.
  template <typename F>
  void update_stats(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    f(stats_);
  }
  const config::TriggerOptions& options() const { return options_; }

 private:
  void thread_main(PulseTrain train);

  config::TriggerOptions options_;
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<uint64_t> sent_{0};
  mutable std::mutex mutex_;
  std::condition_variable done_;
  Stats stats_;
  std::string last_error_;
};

// The host-timed loop: sleeps with clock_nanosleep(TIMER_ABSTIME) until each slot of a PulseScheduler
// grid, emits the leading edge, and (for backends with a physical line) the trailing edge one pulse
// width after the measured leading edge.
class ScheduledGenerator : public ThreadedGenerator {
 public:
  using ThreadedGenerator::ThreadedGenerator;

 protected:
  // Emits the leading edge of `pulse` and sets pulse.t_ns to the time it happened. Throws
  // TriggerError when the output is gone (fatal); transient failures are counted by the backend.
  virtual void leading_edge(Pulse& pulse) = 0;
  // Ends the pulse (only called when has_width()).
  virtual void trailing_edge() {}
  virtual bool has_width() const = 0;

  void run(const PulseTrain& train) final;

 private:
  // Sleeps until the absolute CLOCK_MONOTONIC time, in slices so stop() is noticed; false if stopped.
  bool sleep_until(int64_t t_ns) const;
};

// Sets the calling thread's timer slack to 1 ns and tries SCHED_FIFO at `priority` (0: no real-time
// policy). Returns false, after a one-time informational log line, when the system does not permit it.
bool try_realtime(int priority);

}  // namespace vc::trigger::detail
