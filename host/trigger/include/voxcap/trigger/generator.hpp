// Trigger generation on the host: one interface, three backends selected by name from the rig config.
//
//   udp    the emulated rig's trigger: one 24-byte datagram (proto.h, vc_trigger_dgram_*) per pulse to
//          every edge endpoint on loopback, host-timed (scheduler.hpp) on a real-time thread.
//   gpiod  a GPIO output line through libgpiod v2, host-timed the same way: active for the pulse
//          width, then idle.
//   ftdi   the USB trigger box (hw/triggerbox): an FT232H in synchronous bit-bang mode streaming a
//          precomputed pattern, so the chip's crystal times every edge (bitbang.hpp).
//
// Lifecycle: construct (cheap, no device access) -> start(train) opens the device on first use and
// starts the pulse thread -> stop() (or a finite train ends by itself) -> start() again is allowed.
// Errors: start() throws TriggerError with a message naming the backend and the device; a failure
// while running stops the pulses, and last_error() says why. Every backend counts pulses_sent();
// counts and stats restart with each start().
// Thread-safety: start/stop/wait_done from one controlling thread; the getters from any thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

#include "voxcap/config/options.hpp"

namespace vc::trigger {

struct TriggerError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One emitted pulse.
struct Pulse {
  uint64_t seq = 0;         // pulse counter; every frame of this pulse carries it
  int64_t t_ns = 0;         // CLOCK_MONOTONIC time of the leading edge as this host knows it
                            // (ftdi: estimated from the echo stream, late by at most the echo's
                            // USB delivery delay, about a millisecond)
  int64_t lateness_ns = 0;  // host-timed backends: how late against the schedule; ftdi: 0
};

struct Stats {
  uint64_t pulses_sent = 0;
  uint64_t late = 0;       // host-timed: emitted more than late_threshold after the slot
  uint64_t missed = 0;     // host-timed: slots skipped because the thread was far too late
  uint64_t underruns = 0;  // ftdi: pauses of the chip (its queue ran dry, or its echo was not read in
                           // time) long enough to see (>= 5 ms); pulses after one are late by it
  int64_t paused_ns = 0;   // ftdi: total length of those pauses
  uint64_t errors = 0;     // udp: datagrams that failed to send
  int64_t max_lateness_ns = 0;
  uint64_t pin_edges = 0;     // ftdi: leading edges seen on the pin in the echo (0 on other backends)
  double sample_rate_hz = 0;  // ftdi: measured bit-bang rate (echoed samples / host time)
};

// What to emit.
struct PulseTrain {
  double rate_hz = 60.0;
  double pulse_width_us = 100.0;
  uint64_t count = 0;      // 0: until stop()
  uint64_t first_seq = 0;  // seq of the first pulse

  bool valid(std::string* why) const;
  static PulseTrain from(const config::TriggerOptions& options, uint64_t count = 0);
};

// Called on the generator's thread for each pulse, in seq order (udp: after the sends; gpiod: after
// the trailing edge; ftdi: once the chip's echo shows the pulse); keep it short.
using PulseObserver = std::function<void(const Pulse&)>;

class Generator {
 public:
  virtual ~Generator() = default;
  Generator() = default;
  Generator(const Generator&) = delete;
  Generator& operator=(const Generator&) = delete;

  virtual std::string_view backend() const = 0;
  // Human-readable target ("udp 127.0.0.1:7700, 127.0.0.1:7701", "gpiod /dev/gpiochip0 line 18", ...).
  virtual std::string describe() const = 0;

  // Starts emitting; throws TriggerError (device missing or busy, train invalid, already running).
  virtual void start(const PulseTrain& train) = 0;
  void start(double rate_hz, double pulse_width_us) { start(PulseTrain{rate_hz, pulse_width_us, 0, 0}); }
  // Stops after the pulse in progress, leaves the output idle. Idempotent.
  virtual void stop() = 0;
  // Waits until a finite train has been emitted entirely (or the generator failed or was stopped);
  // true when it is no longer running.
  virtual bool wait_done(std::chrono::milliseconds timeout) = 0;
  virtual bool running() const = 0;

  virtual uint64_t pulses_sent() const = 0;
  virtual Stats stats() const = 0;
  // Why the generator stopped on its own (empty when it did not).
  virtual std::string last_error() const = 0;

  // Set before start().
  void set_observer(PulseObserver observer) { observer_ = std::move(observer); }

 protected:
  PulseObserver observer_;
};

// The backend named by options.backend, configured from the options (nothing opened yet).
std::unique_ptr<Generator> make_generator(const config::TriggerOptions& options);

}  // namespace vc::trigger
