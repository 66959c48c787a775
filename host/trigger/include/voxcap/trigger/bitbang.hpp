// Pure logic of the USB trigger box (an FTDI FT232H-class chip in synchronous bit-bang mode), kept
// apart from the libftdi calls so all of it is unit-tested without a device.
//
// In synchronous bit-bang mode the chip clocks one byte from its TX FIFO onto ADBUS0-7 per tick of
// its bit-bang clock and returns the pin states it sampled, one byte per byte written. The host never
// times a pulse: it streams a precomputed pattern (the trigger pin active for `width` samples at the
// start of each period, idle for the rest) and the chip's crystal sets every edge. The host only
// has to keep the FIFO fed and read the echo back (the chip stalls when its read buffer is full).
//
// - BitbangClock: the bit-bang clock. On H-series chips it is 5x the UART baud rate derived from the
//   12 MHz reference (pyftdi's BITBANG_BAUDRATE_RATIO_HIGH; confirmed by libftdi users' scope
//   measurements), and libftdi multiplies the rate passed to ftdi_set_baudrate() by 4 once bit-bang
//   is on. plan_bitbang_clock() mirrors libftdi's divisor rounding so the effective sample rate is
//   known exactly as a fraction (480 MHz / divisor in 1/8 steps). The hil test measures it.
// - BitbangPattern: pulse k starts at sample lead + floor(k * fs / rate), in exact integer arithmetic,
//   so a period that is not a whole number of samples alternates between floor and ceil (1 sample of
//   jitter) and the train never drifts against the chip's clock.
// - count_leading_edges(): counts pulses seen on the pin in the echoed bytes (a check that the pin
//   really toggles: a shorted or overloaded output shows fewer).
// - StreamLedger: bytes queued vs bytes echoed; all queued bytes echoed while the pattern goes on means
//   the FIFO ran dry and the chip paused (an underrun: the pulses after it are late by the gap).
// - StreamTimebase: host CLOCK_MONOTONIC time of sample 0, from (read completion time, bytes echoed)
//   pairs: each gives an upper bound, the minimum over a sliding window follows crystal drift. A pause
//   of the chip (its FIFO ran dry, or its echo buffer filled because the host did not read in time)
//   lifts every later bound by the pause's length: when even the smallest of the latest few bounds sits
//   more than a threshold above the earlier minimum, that is a pause, measured and counted. Pauses
//   shorter than the threshold (USB delivery jitter is of that order) go unseen here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <utility>

namespace vc::trigger {

struct BitbangClock {
  int libftdi_baudrate = 0;  // argument for ftdi_set_baudrate() AFTER ftdi_set_bitmode(SYNCBB)
  uint32_t divisor8 = 0;     // the chip's baud divisor, in 1/8 steps of the 12 MHz reference
  uint64_t fs_num = 0;       // effective sample rate = fs_num / fs_den Hz, exactly
  uint64_t fs_den = 1;

  double sample_rate_hz() const { return static_cast<double>(fs_num) / static_cast<double>(fs_den); }
};

// The H-series clock plan for a wanted sample rate in [10 kHz, 1 MHz]. Fails (and says why) outside
// the range where libftdi's 12 MHz-reference branch applies.
std::optional<BitbangClock> plan_bitbang_clock(uint32_t wanted_hz, std::string* why);

struct PatternOptions {
  uint64_t fs_num = 100000;  // sample rate = fs_num / fs_den Hz
  uint64_t fs_den = 1;
  double rate_hz = 60.0;
  double pulse_width_us = 100.0;
  uint8_t pin_mask = 0x08;    // the trigger pin's bit
  bool active_low = false;    // idle high, pulse low
  uint64_t count = 0;         // pulses; 0 = until finish()
  uint64_t lead_samples = 1;  // idle samples before pulse 0, so pulse 0 has a real leading edge

  bool valid(std::string* why) const;
};

class BitbangPattern {
 public:
  // Throws std::invalid_argument when options are not valid() or the width leaves no idle sample
  // between pulses.
  explicit BitbangPattern(const PatternOptions& options);

  // Writes the next bytes of the stream (at most cap); returns how many. 0 once finished().
  size_t fill(uint8_t* out, size_t cap);
  // Ends the stream as early as possible: after the pulse in progress (full width) plus one idle
  // sample, or right away when the pin is idle. No new pulse starts.
  void finish();
  bool finished() const { return end_ && generated_ >= *end_; }

  uint64_t generated() const { return generated_; }
  // Total length of a finite stream (count > 0 or after finish()).
  std::optional<uint64_t> total_samples() const { return end_; }
  // Sample index of pulse k's leading edge.
  uint64_t pulse_start(uint64_t k) const;
  // Pulses whose leading edge lies among the first `samples` samples of the stream.
  uint64_t pulses_started_before(uint64_t samples) const;
  uint64_t width_samples() const { return width_; }
  double period_samples() const;
  uint8_t idle_byte() const { return idle_; }
  uint8_t active_byte() const { return active_; }

 private:
  PatternOptions options_;
  unsigned __int128 a_ = 0;  // samples per period = a_ / b_ = fs_num * 1e6 / (fs_den * rate_uhz)
  unsigned __int128 b_ = 1;
  uint64_t width_ = 1;
  uint8_t idle_ = 0;
  uint8_t active_ = 0;
  uint64_t generated_ = 0;
  uint64_t next_pulse_ = 0;   // index of the next pulse to start
  uint64_t high_end_ = 0;     // end (exclusive) of the last started pulse's active run
  bool last_active_ = false;  // value of the last generated sample
  std::optional<uint64_t> end_;
};

// Counts idle->active transitions of `mask` in echoed pin bytes. `*active` carries the pin's last
// state across calls (start with false: the pin idles before the stream).
uint64_t count_leading_edges(const uint8_t* data, size_t n, uint8_t mask, bool active_low, bool* active);

class StreamLedger {
 public:
  void on_submitted(uint64_t bytes) { submitted_ += bytes; }
  void on_echoed(uint64_t bytes) { echoed_ += bytes; }
  // Call after handling USB events and before queuing more: returns true (once per episode) when the
  // chip has echoed everything queued while the pattern still goes on.
  bool check_underrun(bool pattern_finished);

  uint64_t submitted() const { return submitted_; }
  uint64_t echoed() const { return echoed_; }
  uint64_t queued() const { return submitted_ - echoed_; }
  uint64_t underruns() const { return underruns_; }

 private:
  uint64_t submitted_ = 0;
  uint64_t echoed_ = 0;
  uint64_t underruns_ = 0;
  uint64_t dry_at_ = 0;  // submitted_ when the last underrun was counted
};

class StreamTimebase {
 public:
  StreamTimebase(uint64_t fs_num, uint64_t fs_den, size_t window = 32,
                 int64_t pause_threshold_ns = 5'000'000);

  // At a read completion: `echoed` samples had been clocked out by host time `host_ns`. Returns the
  // length of a chip pause this observation revealed, else 0.
  int64_t observe(int64_t host_ns, uint64_t echoed);
  bool ready() const { return !window_.empty(); }
  // Estimated CLOCK_MONOTONIC time at which the chip clocked out `sample` (requires ready()).
  int64_t host_time_of(uint64_t sample) const;
  // Samples per second of host time between the first and the latest observation, pauses excluded
  // (0 if unknown): the chip's bit-bang clock as the host measures it.
  double measured_rate_hz() const;
  uint64_t pauses() const { return pauses_; }
  int64_t paused_ns() const { return paused_ns_; }

 private:
  int64_t origin_bound(int64_t host_ns, uint64_t echoed) const;
  int64_t sample_ns(uint64_t sample) const;

  static constexpr size_t kRecent = 4;  // a pause must show in this many consecutive bounds

  uint64_t fs_num_;
  uint64_t fs_den_;
  size_t window_size_;
  int64_t pause_threshold_ns_;
  uint64_t pauses_ = 0;
  int64_t paused_ns_ = 0;
  std::deque<int64_t> window_;  // origin upper bounds, newest last
  std::optional<std::pair<int64_t, uint64_t>> first_, last_;
};

}  // namespace vc::trigger
