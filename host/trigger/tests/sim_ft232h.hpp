// A simulated FT232H in synchronous bit-bang mode behind the BitbangIo seam, on a virtual clock, so the
// trigger box's stream loop runs in the unit tests exactly as against the device: writes fill a
// 1 KiB TX FIFO, the chip clocks one byte per tick of its bit-bang clock onto the pins only while its
// 1 KiB echo FIFO has room (that is synchronous mode), echoed bytes reach a pending read after a USB
// delay, and a read completes when it has all the bytes it asked for. Faults on demand: the host
// thread stalling (USB transfers keep going, completions wait), the device unplugged, a pin stuck low.
// Everything the chip drove is logged with its chip time, for the tests to check against the pattern.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bitbang_io.hpp"

namespace vc::trigger::testing {

struct SimOptions {
  uint64_t fs_num = 100000, fs_den = 1;   // bit-bang clock
  size_t tx_fifo = 1024, rx_fifo = 1024;  // FT232H
  int64_t echo_delay_ns = 300'000;        // clocked sample -> visible to a pending read
  int64_t start_ns = 1'000'000'000;       // virtual time at open
  int64_t stall_at_ns = -1;               // first wait at or after this: the host sleeps stall_ns
  int64_t stall_ns = 0;
  int64_t unplug_at_ns = -1;   // from then on every transfer fails
  uint8_t stuck_low_mask = 0;  // pins that read back 0 whatever is driven
  uint8_t initial_pins = 0;    // what the pins drive before the first byte
};

// What the chip did; shared with the test so it outlives the chip (the generator drops the device
// after a failure).
struct SimLog {
  std::vector<uint8_t> driven;    // pin byte of every clocked sample, in order
  std::vector<int64_t> driven_t;  // its chip time
  int opens = 0;
};

class SimFt232h final : public detail::BitbangIo {
 public:
  SimFt232h(SimOptions o, std::shared_ptr<SimLog> log)
      : o_(o), log_(std::move(log)), t_(o.start_ns), pins_(o.initial_pins) {
    ++log_->opens;
  }

  Transfer* submit_write(uint8_t* buf, int size) override {
    if (unplugged()) return nullptr;
    auto* x = new Xfer{true, buf, size};
    writes_.push_back(x);
    return as_t(x);
  }
  Transfer* submit_read(uint8_t* buf, int size) override {
    if (unplugged() || read_) return nullptr;
    read_ = new Xfer{false, buf, size};
    return as_t(read_);
  }
  bool completed(const Transfer* t) const override { return x(t)->done; }
  int finish(Transfer* t) override {
    Xfer* p = x(t);
    const int r = p->failed ? -1 : p->moved;
    forget(p);
    return r;
  }
  void cancel(Transfer* t) override { forget(x(t)); }
  void wait_events(int timeout_us) override {
    if (o_.stall_at_ns >= 0 && t_ >= o_.stall_at_ns) {
      // The host thread is away: the chip and the USB transfers already submitted go on.
      o_.stall_at_ns = -1;
      run_until(t_ + o_.stall_ns, /*return_on_completion=*/false);
      return;
    }
    run_until(t_ + static_cast<int64_t>(timeout_us) * 1000, /*return_on_completion=*/true);
  }
  int64_t now_ns() const override { return t_; }
  std::string error() const override { return unplugged() ? "USB device unavailable" : ""; }

  ~SimFt232h() override {
    for (Xfer* w : writes_) delete w;
    delete read_;
  }

 private:
  struct Xfer {
    bool write;
    uint8_t* buf;
    int size;
    int moved = 0;
    bool done = false;
    bool failed = false;
  };
  static Transfer* as_t(Xfer* p) { return reinterpret_cast<Transfer*>(p); }
  static Xfer* x(const Transfer* t) { return reinterpret_cast<Xfer*>(const_cast<Transfer*>(t)); }

  bool unplugged() const { return o_.unplug_at_ns >= 0 && t_ >= o_.unplug_at_ns; }

  void forget(Xfer* p) {
    writes_.erase(std::remove(writes_.begin(), writes_.end(), p), writes_.end());
    if (read_ == p) read_ = nullptr;
    delete p;
  }

  int64_t tick_time(uint64_t tick) const {
    return o_.start_ns + static_cast<int64_t>(static_cast<unsigned __int128>(tick) * o_.fs_den *
                                              1'000'000'000u / o_.fs_num);
  }

  // One tick of the chip at time `now`; true when a transfer completed.
  bool step(int64_t now) {
    bool completion = false;
    if (unplugged()) {
      for (Xfer* w : writes_) w->done = w->failed = true;
      if (read_) read_->done = read_->failed = true;
      return !writes_.empty() || read_;
    }
    // USB OUT: pending writes into the TX FIFO, in order; a write completes once all of it is in.
    for (Xfer* w : writes_) {
      if (w->done) continue;
      while (w->moved < w->size && tx_.size() < o_.tx_fifo) tx_.push_back(w->buf[w->moved++]);
      if (w->moved < w->size) break;
      w->done = completion = true;
    }
    // The bit-bang clock: sample the pins (the echo), then drive the next byte, if the echo fits.
    if (!tx_.empty() && rx_.size() < o_.rx_fifo) {
      rx_.emplace_back(static_cast<uint8_t>(pins_ & ~o_.stuck_low_mask), now);
      pins_ = tx_.front();
      tx_.pop_front();
      log_->driven.push_back(pins_);
      log_->driven_t.push_back(now);
    }
    // USB IN: echoed bytes old enough reach the pending read.
    if (read_ && !read_->done) {
      while (!rx_.empty() && rx_.front().second + o_.echo_delay_ns <= now && read_->moved < read_->size) {
        read_->buf[read_->moved++] = rx_.front().first;
        rx_.pop_front();
      }
      if (read_->moved == read_->size) read_->done = completion = true;
    }
    return completion;
  }

  void run_until(int64_t end, bool return_on_completion) {
    for (; tick_time(tick_) <= end; ++tick_) {
      const int64_t now = tick_time(tick_);
      t_ = std::max(t_, now);
      if (step(now) && return_on_completion) {
        ++tick_;
        return;
      }
    }
    t_ = std::max(t_, end);
  }

  SimOptions o_;
  std::shared_ptr<SimLog> log_;
  int64_t t_;
  uint64_t tick_ = 0;
  uint8_t pins_;
  std::deque<uint8_t> tx_;
  std::deque<std::pair<uint8_t, int64_t>> rx_;
  std::vector<Xfer*> writes_;
  Xfer* read_ = nullptr;
};

// A factory for detail::FtdiGenerator that opens a simulated chip with the planned clock.
// Like open_libftdi_io, it leaves the trigger pin driving its idle level.
inline detail::BitbangIoFactory sim_factory(SimOptions o, const std::shared_ptr<SimLog>& log) {
  return [o, log](const config::TriggerOptions& options, const BitbangClock& clock) {
    SimOptions so = o;
    so.fs_num = clock.fs_num;
    so.fs_den = clock.fs_den;
    so.initial_pins = options.active_low ? static_cast<uint8_t>(1u << options.ftdi.pin) : 0;
    return std::make_unique<SimFt232h>(so, log);
  };
}

}  // namespace vc::trigger::testing
