// The USB trigger box: an FT232H (or another H-series FTDI chip) in synchronous bit-bang mode. The
// host streams the pulse pattern of bitbang.hpp ahead of time and the chip clocks it out on its own
// crystal, so no host scheduling jitter reaches the cameras. In synchronous mode the chip clocks out a
// byte only when it can store the pin sample it echoes back, so the host must keep a read pending at
// all times: the loop below keeps up to `buffer_ms` of pattern in flight in several asynchronous
// writes and one asynchronous read, and pumps libusb events itself (waiting on one transfer with
// ftdi_transfer_data_done() could let the read lapse and stall the chip).
//
// Pulses sent = pulses whose leading edge lies in the echoed bytes (bytes the chip has clocked out);
// their host times come from StreamTimebase, which also measures pauses of the chip (underruns: the
// queue ran dry, or the echo was not read in time) — counted and logged, not hidden.
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

#include "voxcap/base/clock.hpp"
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

// libftdi's asynchronous transfers behind BitbangIo. libftdi hands out ftdi_transfer_control objects
// whose `completed` flag its callbacks set while libusb events are handled.
class LibftdiIo final : public BitbangIo {
 public:
  explicit LibftdiIo(ftdi_context* ctx) : ctx_(ctx) {}
  ~LibftdiIo() override {
    ftdi_usb_close(ctx_);
    ftdi_free(ctx_);
  }

  Transfer* submit_write(uint8_t* buf, int size) override {
    return as_transfer(ftdi_write_data_submit(ctx_, buf, size));
  }
  Transfer* submit_read(uint8_t* buf, int size) override {
    return as_transfer(ftdi_read_data_submit(ctx_, buf, size));
  }
  bool completed(const Transfer* t) const override { return tc(t)->completed != 0; }
  int finish(Transfer* t) override { return ftdi_transfer_data_done(tc(t)); }
  void cancel(Transfer* t) override {
    timeval tv{0, 100000};
    ftdi_transfer_data_cancel(tc(t), &tv);
  }
  void wait_events(int timeout_us) override {
    timeval tv{0, timeout_us};
    const int rc = libusb_handle_events_timeout_completed(ctx_->usb_ctx, &tv, nullptr);
    if (rc < 0 && rc != LIBUSB_ERROR_INTERRUPTED && rc != LIBUSB_ERROR_TIMEOUT)
      throw TriggerError(fmt::format("ftdi: USB event handling failed: {}", libusb_error_name(rc)));
  }
  int64_t now_ns() const override { return static_cast<int64_t>(vc::monotonic_ns()); }
  std::string error() const override { return ftdi_get_error_string(ctx_); }

 private:
  static Transfer* as_transfer(ftdi_transfer_control* t) { return reinterpret_cast<Transfer*>(t); }
  static ftdi_transfer_control* tc(const Transfer* t) {
    return reinterpret_cast<ftdi_transfer_control*>(const_cast<Transfer*>(t));
  }

  ftdi_context* ctx_;
};

struct InFlight {
  BitbangIo::Transfer* transfer = nullptr;
  int size = 0;
};

}  // namespace

std::unique_ptr<BitbangIo> open_libftdi_io(const config::TriggerOptions& options, const BitbangClock& clock) {
  const config::FtdiTriggerOptions& o = options.ftdi;
  const std::string dev = o.device_str();
  ftdi_context* ctx = ftdi_new();
  if (!ctx) throw TriggerError("ftdi: cannot initialise libftdi (libusb_init failed)");
  auto fail = [&](const std::string& message) {
    ftdi_usb_close(ctx);
    ftdi_free(ctx);
    throw TriggerError(message);
  };
  if (ftdi_set_interface(ctx, static_cast<ftdi_interface>(INTERFACE_A + (o.interface - 'A'))) < 0)
    fail(fmt::format("ftdi: interface {}: {}", o.interface, ftdi_get_error_string(ctx)));
  const int rc =
      ftdi_usb_open_desc(ctx, o.vid, o.pid, o.description.empty() ? nullptr : o.description.c_str(),
                         o.serial.empty() ? nullptr : o.serial.c_str());
  if (rc == -3)
    fail(fmt::format("ftdi: no device {:04x}:{:04x} found{}{}", o.vid, o.pid,
                     o.serial.empty() ? "" : " with serial " + o.serial,
                     o.description.empty() ? "" : " named \"" + o.description + "\""));
  if (rc == -4 || rc == -8 || rc == -9 || rc == -10)
    fail(
        fmt::format("ftdi: cannot open {}: {} (permissions? install hw/udev/60-voxcap.rules and join the "
                    "plugdev group)",
                    dev, ftdi_get_error_string(ctx)));
  if (rc == -5 || rc == -6)
    fail(fmt::format("ftdi: {} is busy: {} (another program holds it)", dev, ftdi_get_error_string(ctx)));
  if (rc < 0) fail(fmt::format("ftdi: opening {} failed: {}", dev, ftdi_get_error_string(ctx)));

  if (!is_h_series(ctx->type))
    fail(
        fmt::format("ftdi: {} is an {}; the trigger box needs an H-series chip (FT232H, FT2232H, FT4232H), "
                    "whose synchronous bit-bang clock is exact",
                    dev, chip_name(ctx->type)));
  const uint8_t out_mask = static_cast<uint8_t>(1u << o.pin);
  const uint8_t idle = options.active_low ? out_mask : 0;
  // Enter bit-bang with every pin an input (the box's R1 holds the line idle), clock the idle level
  // into the output latch, and only then make the trigger pin an output: it starts at its idle level
  // instead of the latch's power-up 0, which would be a spurious pulse on an active-low rig.
  if (ftdi_tcioflush(ctx) < 0 || ftdi_set_latency_timer(ctx, 2) < 0 ||
      ftdi_set_bitmode(ctx, 0x00, BITMODE_SYNCBB) < 0 || ftdi_set_baudrate(ctx, clock.libftdi_baudrate) < 0)
    fail(fmt::format("ftdi: configuring {} for synchronous bit-bang failed: {}", dev,
                     ftdi_get_error_string(ctx)));
  uint8_t byte = idle;
  if (ftdi_write_data(ctx, &byte, 1) != 1)
    fail(fmt::format("ftdi: writing the idle level to {} failed: {}", dev, ftdi_get_error_string(ctx)));
  int echoed = 0;
  for (int tries = 0; tries < 100 && echoed == 0; ++tries) echoed = ftdi_read_data(ctx, &byte, 1);
  if (echoed != 1 || ftdi_set_bitmode(ctx, out_mask, BITMODE_SYNCBB) < 0 || ftdi_tcioflush(ctx) < 0)
    fail(fmt::format("ftdi: setting ADBUS{} of {} as the trigger output failed: {}", o.pin, dev,
                     ftdi_get_error_string(ctx)));
  spdlog::info("trigger: {} ({}) in synchronous bit-bang at {:.6g} Hz, trigger on ADBUS{}", dev,
               chip_name(ctx->type), clock.sample_rate_hz(), o.pin);
  return std::make_unique<LibftdiIo>(ctx);
}

FtdiGenerator::FtdiGenerator(const config::TriggerOptions& options, BitbangIoFactory open_io)
    : ThreadedGenerator(options),
      ftdi_(options.ftdi),
      active_low_(options.active_low),
      open_io_(std::move(open_io)) {}

FtdiGenerator::~FtdiGenerator() {
  stop();
  io_.reset();
}

std::string FtdiGenerator::describe() const {
  return fmt::format("ftdi {} interface {} ADBUS{}{} at {} Hz bit-bang", ftdi_.device_str(), ftdi_.interface,
                     ftdi_.pin, active_low_ ? " (active low)" : "", ftdi_.sample_rate_hz);
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
  clock_ = *clock;
  if (!io_) io_ = open_io_(options(), clock_);
}

void FtdiGenerator::run(const PulseTrain& train) {
  PatternOptions po;
  po.fs_num = clock_.fs_num;
  po.fs_den = clock_.fs_den;
  po.rate_hz = train.rate_hz;
  po.pulse_width_us = train.pulse_width_us;
  po.pin_mask = static_cast<uint8_t>(1u << ftdi_.pin);
  po.active_low = active_low_;
  po.count = train.count;
  BitbangPattern pattern(po);
  StreamLedger ledger;
  StreamTimebase timebase(clock_.fs_num, clock_.fs_den);
  BitbangIo& io = *io_;

  const double fs = clock_.sample_rate_hz();
  const size_t chunk = std::max<size_t>(64, static_cast<size_t>(fs * kChunkSeconds));
  const uint64_t max_queued =
      std::max<uint64_t>(2 * chunk, static_cast<uint64_t>(fs * ftdi_.buffer_ms / 1000.0));
  const size_t max_writes = static_cast<size_t>(max_queued / chunk) + 1;
  // One buffer more than writes in flight: the one refilled next is never still being sent.
  std::vector<std::vector<uint8_t>> buffers(max_writes + 1, std::vector<uint8_t>(chunk));
  std::vector<uint8_t> echo(chunk);
  std::deque<InFlight> writes;
  size_t next_buffer = 0;
  BitbangIo::Transfer* read = nullptr;
  bool pin_active = false;
  uint64_t reported = 0;
  int64_t last_progress = io.now_ns();

  auto cancel_all = [&] {
    if (read) io.cancel(read);
    read = nullptr;
    for (InFlight& w : writes) io.cancel(w.transfer);
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
        BitbangIo::Transfer* t = io.submit_write(buf.data(), static_cast<int>(n));
        if (!t) throw TriggerError(fmt::format("ftdi: submitting a USB write failed: {}", io.error()));
        writes.push_back({t, static_cast<int>(n)});
        next_buffer = (next_buffer + 1) % buffers.size();
        ledger.on_submitted(n);
      }
      // Always have a read pending while the chip has bytes to clock out.
      if (!read && ledger.queued() > 0) {
        const int size = static_cast<int>(std::min<uint64_t>(ledger.queued(), echo.size()));
        read = io.submit_read(echo.data(), size);
        if (!read) throw TriggerError(fmt::format("ftdi: submitting a USB read failed: {}", io.error()));
      }
      if (!read && writes.empty()) break;  // pattern finished and fully echoed

      // A read can complete at submission (libftdi had echo bytes left over from a larger USB
      // transfer): then take it at once rather than wait for an event with no read pending.
      if (!(read && io.completed(read))) io.wait_events(20000);
      const int64_t now = io.now_ns();

      if (read && io.completed(read)) {
        const int n = io.finish(read);
        read = nullptr;
        if (n < 0) throw TriggerError("ftdi: USB read failed (device unplugged?)");
        if (n > 0) {
          last_progress = now;
          ledger.on_echoed(static_cast<uint64_t>(n));
          const int64_t pause_ns = timebase.observe(now, ledger.echoed());
          if (pause_ns > 0) {
            update_stats([&](Stats& s) {
              ++s.underruns;
              s.paused_ns += pause_ns;
            });
            spdlog::warn(
                "trigger: the ftdi chip paused for {:.1f} ms: the pulses after it are late by that much "
                "(raise trigger.ftdi.buffer_ms or the pulse thread's priority)",
                static_cast<double>(pause_ns) / 1e6);
          }
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
      while (!writes.empty() && io.completed(writes.front().transfer)) {
        const InFlight w = writes.front();
        writes.pop_front();
        const int n = io.finish(w.transfer);
        if (n != w.size)
          throw TriggerError(fmt::format("ftdi: USB write failed ({} of {} bytes)", n, w.size));
      }
      // Certain but possibly short: the chip clocked out everything queued and waits. Counted once
      // it shows in the echo timing (StreamTimebase); said at once here.
      if (ledger.check_underrun(pattern.finished()))
        spdlog::warn("trigger: the ftdi pattern queue ran dry; the chip waits for data");
      if (ledger.queued() > 0 && now - last_progress > kStallTimeoutNs)
        throw TriggerError(
            fmt::format("ftdi: {} stopped echoing bit-bang samples (unplugged?)", ftdi_.device_str()));
    }
  } catch (...) {
    cancel_all();
    io_.reset();  // unknown state: reopen on the next start()
    throw;
  }
}

}  // namespace vc::trigger::detail
