// Internal: the three backends. Only the factory (generator.cpp) and the tests see these classes;
// everyone else holds a vc::trigger::Generator. Each device API appears only in its backend's file.
#pragma once

#include "voxcap/auth.h"

#include <netinet/in.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bitbang_io.hpp"
#include "threaded_generator.hpp"

struct gpiod_chip;
struct gpiod_line_request;

namespace vc::trigger::detail {

class UdpGenerator final : public ScheduledGenerator {
 public:
  explicit UdpGenerator(const config::TriggerOptions& options);
  ~UdpGenerator() override;

  std::string_view backend() const override { return "udp"; }
  std::string describe() const override;

 protected:
  void prepare(const PulseTrain& train) override;
  void leading_edge(Pulse& pulse) override;
  bool has_width() const override { return false; }

 private:
  std::vector<config::Endpoint> targets_;
  std::vector<sockaddr_in> addrs_;
  std::vector<bool> warned_;
  bool keyed_ = false;  // the rig key is set: version-2 datagrams with MAC and counter
  vc_mac mac_{};
  int fd_ = -1;
};

class GpiodGenerator final : public ScheduledGenerator {
 public:
  explicit GpiodGenerator(const config::TriggerOptions& options);
  ~GpiodGenerator() override;

  std::string_view backend() const override { return "gpiod"; }
  std::string describe() const override;

 protected:
  void prepare(const PulseTrain& train) override;
  void leading_edge(Pulse& pulse) override;
  void trailing_edge() override;
  bool has_width() const override { return true; }

 private:
  void release();

  config::GpiodTriggerOptions gpio_;
  bool active_low_ = false;
  gpiod_chip* chip_ = nullptr;
  gpiod_line_request* request_ = nullptr;
  unsigned offset_ = 0;
};

class FtdiGenerator final : public ThreadedGenerator {
 public:
  // `open_io` opens the device (default: libftdi); the tests pass a simulated chip.
  explicit FtdiGenerator(const config::TriggerOptions& options, BitbangIoFactory open_io = open_libftdi_io);
  ~FtdiGenerator() override;

  std::string_view backend() const override { return "ftdi"; }
  std::string describe() const override;

 protected:
  void prepare(const PulseTrain& train) override;
  void run(const PulseTrain& train) override;

 private:
  config::FtdiTriggerOptions ftdi_;
  bool active_low_ = false;
  BitbangIoFactory open_io_;
  std::unique_ptr<BitbangIo> io_;  // open between a successful prepare() and a failure or destruction
  BitbangClock clock_;             // the planned bit-bang clock (bitbang.hpp), exact
};

}  // namespace vc::trigger::detail
