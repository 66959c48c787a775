// Internal: the USB side of the trigger box's bit-bang stream, as the stream loop (ftdi_generator.cpp)
// uses it. The real implementation wraps libftdi's asynchronous transfers; the unit tests drive the same
// loop against a simulated FT232H (FIFOs, bit-bang clock, echo), so the loop is tested without a device.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "voxcap/config/options.hpp"
#include "voxcap/trigger/bitbang.hpp"

namespace vc::trigger::detail {

class BitbangIo {
 public:
  struct Transfer;  // opaque to the loop
  virtual ~BitbangIo() = default;

  // Submits an asynchronous write of `size` bytes (the buffer stays valid until finish()/cancel())
  // or read (at most one pending). nullptr on failure; error() says why.
  virtual Transfer* submit_write(uint8_t* buf, int size) = 0;
  virtual Transfer* submit_read(uint8_t* buf, int size) = 0;
  virtual bool completed(const Transfer* t) const = 0;
  // Releases a completed transfer: bytes moved, or < 0 on failure.
  virtual int finish(Transfer* t) = 0;
  // Releases a transfer that may still be pending.
  virtual void cancel(Transfer* t) = 0;
  // Handles USB events for up to timeout_us (returns earlier when a transfer completes). Throws
  // TriggerError when the USB stack fails.
  virtual void wait_events(int timeout_us) = 0;
  // The clock the stream's timebase is on: CLOCK_MONOTONIC for the device.
  virtual int64_t now_ns() const = 0;
  virtual std::string error() const = 0;
};

// Opens and configures the device (trigger.ftdi, trigger.active_low) for a bit-bang clock, with the
// trigger pin an output driving its idle level; throws TriggerError naming the device.
using BitbangIoFactory =
    std::function<std::unique_ptr<BitbangIo>(const config::TriggerOptions&, const BitbangClock&)>;

// The libftdi implementation: opens the FT232H-class device and sets synchronous bit-bang mode.
std::unique_ptr<BitbangIo> open_libftdi_io(const config::TriggerOptions& options, const BitbangClock& clock);

}  // namespace vc::trigger::detail
