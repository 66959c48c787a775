// The USB trigger box: an FT232H (or another H-series FTDI chip) in synchronous bit-bang mode. The
// host streams the pulse pattern of bitbang.hpp ahead of time and the chip clocks it out on its own
// crystal, so no host scheduling jitter reaches the cameras. In synchronous mode the chip clocks out a
// byte only when it can store the pin sample it echoes back, so the host must keep a read pending at
// all times: the loop below keeps up to `buffer_ms` of pattern in flight in several asynchronous
// writes and one asynchronous read, and pumps libusb events itself (waiting on one transfer with
// ftdi_transfer_data_done() could let the read lapse and stall the chip).
//
// Pulses sent = pulses whose leading edge lies in the echoed bytes (bytes the chip has clocked out);
// their host times come from StreamTimebase. Underruns (the queue ran dry) are counted, not hidden.
// On stop the pattern ends after the pulse in progress, everything is drained, and the pin is left
// idle in bit-bang mode (resetting the mode would hand ADBUS back to the UART, whose TXD idles high).
#include "backends.hpp"

#include <libftdi1/ftdi.h>
#include <libusb.h>

#include <algorithm>
#include <deque>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "voxcap/trigger/bitbang.hpp"

namespace vc::trigger::detail {
namespace {

// Pattern chunk per USB write, as a duration of the bit-bang clock.
constexpr double kChunkSeconds = 0.005;
// No echo for this long while bytes are queued: the device is gone or wedged.
constexpr int64_t kStallTimeoutNs = 2'000'000'000;

bool is_h_series(ftdi_chip_type type) {
  return type == TYPE_232H || type == TYPE_2232H || type == TYPE_4232H;
}

std::string chip_name(ftdi_chip_type type) {
  switch (type) {
    case TYPE_AM:
      return "FT8U232AM";
    case TYPE_BM:
      return "FT232BM";
    case TYPE_2232C:
      return "FT2232C/D";
    case TYPE_R:
      return "FT232R";
    case TYPE_2232H:
      return "FT2232H";
    case TYPE_4232H:
      return "FT4232H";
    case TYPE_232H:
      return "FT232H";
    case TYPE_230X:
      return "FT230X";
    default:
      return "unknown FTDI chip";
  }
}

struct InFlight {
  ftdi_transfer_control* tc = nullptr;
  size_t buffer = 0;
  int size = 0;
};

}  // namespace

FtdiGenerator::FtdiGenerator(const config::TriggerOptions& options)
    : ThreadedGenerator(options), ftdi_(options.ftdi), active_low_(options.active_low) {}

FtdiGenerator::~FtdiGenerator() {
  stop();
  close_device();
}

std::string FtdiGenerator::describe() const {
  return fmt::format("ftdi {} interface {} ADBUS{}{} at {} Hz bit-bang", ftdi_.device_str(), ftdi_.interface,
                     ftdi_.pin, active_low_ ? " (active low)" : "", ftdi_.sample_rate_hz);
}

void FtdiGenerator::close_device() {
  if (!ctx_) return;
  ftdi_usb_close(ctx_);
  ftdi_free(ctx_);
  ctx_ = nullptr;
}

void FtdiGenerator::prepare(const PulseTrain& train) {
  std::string why;
  if (!ftdi_.valid(&why)) throw TriggerError("ftdi: trigger.ftdi." + why);
  const std::optional<BitbangClock> clock = plan_bitbang_clock(ftdi_.sample_rate_hz, &why);
  if (!clock) throw TriggerError("ftdi: " + why);
  // Check the train against the sample clock before touching the device.
  PatternOptions po;
  po.fs_num = clock->fs_num;
  po.fs_den = clock->fs_den;
  po.rate_hz = train.rate_hz;
  po.pulse_width_us = train.pulse_width_us;
  po.pin_mask = static_cast<uint8_t>(1u << ftdi_.pin);
  try {
    BitbangPattern check(po);
  } catch (const std::invalid_argument& e) {
    throw TriggerError(fmt::format("ftdi: {}", e.what()));
  }
  fs_num_ = clock->fs_num;
  fs_den_ = clock->fs_den;
  if (ctx_) return;

  const std::string dev = ftdi_.device_str();
  ctx_ = ftdi_new();
  if (!ctx_) throw TriggerError("ftdi: cannot initialise libftdi (libusb_init failed)");
  auto fail = [&](const std::string& message) {
    close_device();
    throw TriggerError(message);
  };
  if (ftdi_set_interface(ctx_, static_cast<ftdi_interface>(INTERFACE_A + (ftdi_.interface - 'A'))) < 0)
    fail(fmt::format("ftdi: interface {}: {}", ftdi_.interface, ftdi_get_error_string(ctx_)));
  const int rc = ftdi_usb_open_desc(ctx_, ftdi_.vid, ftdi_.pid,
                                    ftdi_.description.empty() ? nullptr : ftdi_.description.c_str(),
                                    ftdi_.serial.empty() ? nullptr : ftdi_.serial.c_str());
  if (rc == -3)
    fail(fmt::format("ftdi: no device {:04x}:{:04x} found{}{}", ftdi_.vid, ftdi_.pid,
                     ftdi_.serial.empty() ? "" : " with serial " + ftdi_.serial,
                     ftdi_.description.empty() ? "" : " named \"" + ftdi_.description + "\""));
  if (rc == -4 || rc == -8 || rc == -9 || rc == -10)
    fail(
        fmt::format("ftdi: cannot open {}: {} (permissions? install hw/udev/60-voxcap.rules and join the "
                    "plugdev group)",
                    dev, ftdi_get_error_string(ctx_)));
  if (rc == -5 || rc == -6)
    fail(fmt::format("ftdi: {} is busy: {} (another program holds it)", dev, ftdi_get_error_string(ctx_)));
  if (rc < 0) fail(fmt::format("ftdi: opening {} failed: {}", dev, ftdi_get_error_string(ctx_)));

  if (!is_h_series(ctx_->type))
    fail(
        fmt::format("ftdi: {} is an {}; the trigger box needs an H-series chip (FT232H, FT2232H, FT4232H), "
                    "whose synchronous bit-bang clock is exact",
                    dev, chip_name(ctx_->type)));
  const uint8_t out_mask = static_cast<uint8_t>(1u << ftdi_.pin);
  if (ftdi_tcioflush(ctx_) < 0 || ftdi_set_latency_timer(ctx_, 2) < 0 ||
      ftdi_set_bitmode(ctx_, out_mask, BITMODE_SYNCBB) < 0 ||
      ftdi_set_baudrate(ctx_, clock->libftdi_baudrate) < 0)
    fail(fmt::format("ftdi: configuring {} for synchronous bit-bang failed: {}", dev,
                     ftdi_get_error_string(ctx_)));
  spdlog::info("trigger: {} ({}) in synchronous bit-bang at {:.6g} Hz, trigger on ADBUS{}", dev,
               chip_name(ctx_->type), clock->sample_rate_hz(), ftdi_.pin);
}

void FtdiGenerator::run(const PulseTrain& train) {
  PatternOptions po;
  po.fs_num = fs_num_;
  po.fs_den = fs_den_;
  po.rate_hz = train.rate_hz;
  po.pulse_width_us = train.pulse_width_us;
  po.pin_mask = static_cast<uint8_t>(1u << ftdi_.pin);
  po.active_low = active_low_;
  po.count = train.count;
  BitbangPattern pattern(po);
  StreamLedger ledger;
  StreamTimebase timebase(fs_num_, fs_den_);

  const double fs = static_cast<double>(fs_num_) / static_cast<double>(fs_den_);
  const size_t chunk = std::max<size_t>(64, static_cast<size_t>(fs * kChunkSeconds));
  const uint64_t max_queued =
      std::max<uint64_t>(2 * chunk, static_cast<uint64_t>(fs * ftdi_.buffer_ms / 1000.0));
  const size_t max_writes = static_cast<size_t>(max_queued / chunk) + 1;
  std::vector<std::vector<uint8_t>> buffers(max_writes + 1, std::vector<uint8_t>(chunk));
  std::vector<uint8_t> echo(chunk);
  std::deque<InFlight> writes;
  size_t next_buffer = 0;
  ftdi_transfer_control* read = nullptr;
  bool pin_active = false;
  uint64_t reported = 0;
  int64_t last_progress = monotonic_ns();

  auto cancel_all = [&] {
    timeval tv{0, 100000};
    if (read) ftdi_transfer_data_cancel(read, &tv);
    read = nullptr;
    for (InFlight& w : writes) ftdi_transfer_data_cancel(w.tc, &tv);
    writes.clear();
  };

  try {
    for (;;) {
      if (stop_requested() && !pattern.finished()) pattern.finish();

      // Keep the chip's FIFO fed: up to max_queued bytes of pattern in flight.
      while (!pattern.finished() && writes.size() < max_writes && ledger.queued() < max_queued) {
        std::vector<uint8_t>& buf = buffers[next_buffer];
        const size_t n = pattern.fill(buf.data(), buf.size());
        if (n == 0) break;
        ftdi_transfer_control* tc = ftdi_write_data_submit(ctx_, buf.data(), static_cast<int>(n));
        if (!tc)
          throw TriggerError(
              fmt::format("ftdi: submitting a USB write failed: {}", ftdi_get_error_string(ctx_)));
        writes.push_back({tc, next_buffer, static_cast<int>(n)});
        next_buffer = (next_buffer + 1) % buffers.size();
        ledger.on_submitted(n);
      }
      // Always have a read pending while the chip has bytes to clock out.
      if (!read && ledger.queued() > 0) {
        const int size = static_cast<int>(std::min<uint64_t>(ledger.queued(), echo.size()));
        read = ftdi_read_data_submit(ctx_, echo.data(), size);
        if (!read)
          throw TriggerError(
              fmt::format("ftdi: submitting a USB read failed: {}", ftdi_get_error_string(ctx_)));
      }
      if (!read && writes.empty()) break;  // pattern finished and fully echoed

      // A read can complete at submission (libftdi had echo bytes left over from a larger USB
      // transfer): then take it at once rather than wait for an event with no read pending.
      if (!(read && read->completed)) {
        timeval tv{0, 20000};
        const int rc = libusb_handle_events_timeout_completed(ctx_->usb_ctx, &tv, nullptr);
        if (rc < 0 && rc != LIBUSB_ERROR_INTERRUPTED && rc != LIBUSB_ERROR_TIMEOUT)
          throw TriggerError(fmt::format("ftdi: USB event handling failed: {}", libusb_error_name(rc)));
      }
      const int64_t now = monotonic_ns();

      if (read && read->completed) {
        const int n = ftdi_transfer_data_done(read);
        read = nullptr;
        if (n < 0) throw TriggerError("ftdi: USB read failed (device unplugged?)");
        if (n > 0) {
          last_progress = now;
          ledger.on_echoed(static_cast<uint64_t>(n));
          timebase.observe(now, ledger.echoed());
          const uint64_t edges =
              count_leading_edges(echo.data(), static_cast<size_t>(n), po.pin_mask, active_low_, &pin_active);
          const double rate = timebase.measured_rate_hz();
          update_stats([&](Stats& s) {
            s.pin_edges += edges;
            s.sample_rate_hz = rate;
          });
          const uint64_t started = pattern.pulses_started_before(ledger.echoed());
          for (; reported < started; ++reported) {
            Pulse pulse;
            pulse.seq = train.first_seq + reported;
            pulse.t_ns = timebase.host_time_of(pattern.pulse_start(reported));
            record_pulse(pulse);
          }
        }
      }
      while (!writes.empty() && writes.front().tc->completed) {
        const InFlight w = writes.front();
        writes.pop_front();
        const int n = ftdi_transfer_data_done(w.tc);
        if (n != w.size)
          throw TriggerError(fmt::format("ftdi: USB write failed ({} of {} bytes)", n, w.size));
      }
      if (ledger.check_underrun(pattern.finished())) {
        update_stats([](Stats& s) { ++s.underruns; });
        spdlog::warn(
            "trigger: ftdi pattern underrun: the chip paused, pulses after it are late (raise "
            "trigger.ftdi.buffer_ms or the thread's priority)");
      }
      if (ledger.queued() > 0 && now - last_progress > kStallTimeoutNs)
        throw TriggerError(
            fmt::format("ftdi: {} stopped echoing bit-bang samples (unplugged?)", ftdi_.device_str()));
    }
  } catch (...) {
    cancel_all();
    close_device();  // unknown state: reopen on the next start()
    throw;
  }
}

}  // namespace vc::trigger::detail
