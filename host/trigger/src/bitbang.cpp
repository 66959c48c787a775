// Clock plan, pattern, echo accounting and timebase of the FT232H trigger box; see bitbang.hpp.
#include "voxcap/trigger/bitbang.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

namespace vc::trigger {
namespace {

using u128 = unsigned __int128;

// libftdi's H-series constants: 120 MHz / 10 = 12 MHz UART reference; the divisor has 3 fractional
// bits, so in 1/8 steps baud = 96 MHz / divisor8; the bit-bang clock is 5x the baud rate.
constexpr uint64_t kBaudTimes8 = 96'000'000;
constexpr uint64_t kBitbangPerBaud = 5;
constexpr int kLibftdiBitbangFactor = 4;

bool fail(std::string* why, std::string message) {
  if (why) *why = std::move(message);
  return false;
}

}  // namespace

std::optional<BitbangClock> plan_bitbang_clock(uint32_t wanted_hz, std::string* why) {
  if (wanted_hz < 10000 || wanted_hz > 1000000) {
    fail(why, fmt::format("bit-bang sample rate must be in [10000, 1000000] Hz, got {}", wanted_hz));
    return std::nullopt;
  }
  BitbangClock clock;
  // The UART baud whose 5x is the wanted sample rate, expressed as what libftdi expects (it
  // multiplies by 4 in bit-bang mode).
  clock.libftdi_baudrate = static_cast<int>(
      std::lround(static_cast<double>(wanted_hz) / (kBitbangPerBaud * kLibftdiBitbangFactor)));
  const uint64_t baud = static_cast<uint64_t>(clock.libftdi_baudrate) * kLibftdiBitbangFactor;
  // Mirror of libftdi's ftdi_to_clkbits(baud, 120 MHz, 10): divisor in 1/16 steps, rounded half up
  // to 1/8 steps. Our range keeps baud between 2 kHz and 200 kHz: the general branch, far from the
  // sub-integer divisors 0, 1.5 and 2, and above libftdi's 12 MHz-reference cut-off (733 baud).
  const uint64_t divisor16 = 2 * kBaudTimes8 / baud;
  clock.divisor8 = static_cast<uint32_t>((divisor16 & 1) ? divisor16 / 2 + 1 : divisor16 / 2);
  clock.fs_num = kBaudTimes8 * kBitbangPerBaud;  // 480 MHz
  clock.fs_den = clock.divisor8;
  return clock;
}

bool PatternOptions::valid(std::string* why) const {
  if (fs_num == 0 || fs_den == 0) return fail(why, "sample rate: must be > 0");
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    return fail(why, fmt::format("rate_hz: must be in (0, 1000], got {}", rate_hz));
  if (!(pulse_width_us > 0.0) || !std::isfinite(pulse_width_us))
    return fail(why, fmt::format("pulse_width_us: must be > 0, got {}", pulse_width_us));
  if (pin_mask == 0 || (pin_mask & (pin_mask - 1)) != 0)
    return fail(why, fmt::format("pin_mask: must have exactly one bit set, got 0x{:02x}", pin_mask));
  return true;
}

BitbangPattern::BitbangPattern(const PatternOptions& options) : options_(options) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument("bit-bang pattern: " + why);
  const uint64_t rate_uhz = static_cast<uint64_t>(std::llround(options.rate_hz * 1e6));
  a_ = static_cast<u128>(options.fs_num) * 1'000'000u;
  b_ = static_cast<u128>(options.fs_den) * rate_uhz;
  const double fs = static_cast<double>(options.fs_num) / static_cast<double>(options.fs_den);
  width_ = static_cast<uint64_t>(std::max<long long>(1, std::llround(options.pulse_width_us * 1e-6 * fs)));
  const uint64_t min_period = static_cast<uint64_t>(a_ / b_);
  if (width_ + 1 > min_period)
    throw std::invalid_argument(fmt::format(
        "bit-bang pattern: a {} us pulse is {} samples but a period is only {} samples at {:.6g} Hz: "
        "no idle sample would separate the pulses",
        options.pulse_width_us, width_, min_period, fs));
  // Only the trigger pin is an output (the others are inputs in the bit-bang mask), so the other
  // bits of each byte are don't-cares, written as 0.
  idle_ = options.active_low ? options.pin_mask : 0;
  active_ = options.active_low ? 0 : options.pin_mask;
  if (options.count > 0) end_ = pulse_start(options.count - 1) + width_ + 1;
}

uint64_t BitbangPattern::pulse_start(uint64_t k) const {
  return options_.lead_samples + static_cast<uint64_t>(static_cast<u128>(k) * a_ / b_);
}

uint64_t BitbangPattern::pulses_started_before(uint64_t samples) const {
  if (samples <= options_.lead_samples) return 0;
  const u128 c = samples - options_.lead_samples;
  // lead + floor(k a / b) < samples  <=>  k a < c b  <=>  k < c b / a  <=>  k <= ceil(c b / a) - 1.
  const uint64_t n = static_cast<uint64_t>((c * b_ + a_ - 1) / a_);
  return options_.count > 0 ? std::min(n, options_.count) : n;
}

double BitbangPattern::period_samples() const {
  return static_cast<double>(a_) / static_cast<double>(b_);
}

size_t BitbangPattern::fill(uint8_t* out, size_t cap) {
  size_t n = 0;
  const uint64_t pulse_limit = options_.count > 0 ? options_.count : std::numeric_limits<uint64_t>::max();
  while (n < cap && !finished()) {
    const uint64_t i = generated_;
    uint64_t boundary;
    uint8_t value;
    if (i < high_end_) {
      value = active_;
      boundary = high_end_;
    } else {
      // After finish() no pulse can start before end_: a period is longer than width + 1 samples.
      const uint64_t next =
          next_pulse_ < pulse_limit ? pulse_start(next_pulse_) : std::numeric_limits<uint64_t>::max();
      if (i == next) {
        high_end_ = next + width_;
        ++next_pulse_;
        value = active_;
        boundary = high_end_;
      } else {
        value = idle_;
        boundary = next;
      }
    }
    if (end_) boundary = std::min(boundary, *end_);
    const size_t run = static_cast<size_t>(std::min<uint64_t>(boundary - i, cap - n));
    std::memset(out + n, value, run);
    n += run;
    generated_ += run;
    last_active_ = value == active_;
  }
  return n;
}

void BitbangPattern::finish() {
  if (end_) return;
  end_ = last_active_ ? high_end_ + 1 : generated_;
}

uint64_t count_leading_edges(const uint8_t* data, size_t n, uint8_t mask, bool active_low, bool* active) {
  uint64_t edges = 0;
  bool state = *active;
  for (size_t i = 0; i < n; ++i) {
    const bool now = ((data[i] & mask) != 0) != active_low;
    if (now && !state) ++edges;
    state = now;
  }
  *active = state;
  return edges;
}

bool StreamLedger::check_underrun(bool pattern_finished) {
  if (pattern_finished || submitted_ == 0 || echoed_ < submitted_ || dry_at_ == submitted_) return false;
  dry_at_ = submitted_;
  ++underruns_;
  return true;
}

StreamTimebase::StreamTimebase(uint64_t fs_num, uint64_t fs_den, size_t window, int64_t pause_threshold_ns)
    : fs_num_(fs_num),
      fs_den_(fs_den),
      window_size_(std::max<size_t>(2 * kRecent, window)),
      pause_threshold_ns_(pause_threshold_ns) {
  if (fs_num == 0 || fs_den == 0) throw std::invalid_argument("stream timebase: sample rate must be > 0");
}

int64_t StreamTimebase::sample_ns(uint64_t sample) const {
  return static_cast<int64_t>(static_cast<u128>(sample) * fs_den_ * 1'000'000'000u / fs_num_);
}

int64_t StreamTimebase::origin_bound(int64_t host_ns, uint64_t echoed) const {
  // The echo of sample echoed-1 exists, so it was clocked out before host_ns.
  return echoed == 0 ? host_ns : host_ns - sample_ns(echoed - 1);
}

int64_t StreamTimebase::observe(int64_t host_ns, uint64_t echoed) {
  if (echoed == 0) return 0;
  window_.push_back(origin_bound(host_ns, echoed));
  if (window_.size() > window_size_) window_.pop_front();
  if (!first_) first_ = {host_ns, echoed};
  last_ = {host_ns, echoed};
  if (window_.size() <= kRecent) return 0;
  const auto split = window_.end() - static_cast<std::ptrdiff_t>(kRecent);
  const int64_t before = *std::min_element(window_.begin(), split);
  const int64_t recent = *std::min_element(split, window_.end());
  if (recent - before <= pause_threshold_ns_) return 0;
  // The chip's timeline moved on by the pause: forget the bounds from before it.
  window_.erase(window_.begin(), split);
  ++pauses_;
  paused_ns_ += recent - before;
  return recent - before;
}

int64_t StreamTimebase::host_time_of(uint64_t sample) const {
  const int64_t origin = *std::min_element(window_.begin(), window_.end());
  return origin + sample_ns(sample);
}

double StreamTimebase::measured_rate_hz() const {
  if (!first_ || !last_ || last_->first <= first_->first) return 0.0;
  const int64_t running_ns = last_->first - first_->first - paused_ns_;
  if (running_ns <= 0) return 0.0;
  return static_cast<double>(last_->second - first_->second) * 1e9 / static_cast<double>(running_ns);
}

}  // namespace vc::trigger
