// The generators through their public interface: the udp backend end to end over loopback (a test
// receiver decodes every datagram), and the gpiod/ftdi backends' errors when there is no device.
// No timing is asserted: only counts, order and that times are plausible (inside the test's window).
#include "voxcap/trigger/generator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include "voxcap/base/clock.hpp"
#include "voxcap/proto.h"

namespace vc::trigger {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;

// A UDP socket on 127.0.0.1 with an ephemeral port, collecting decoded trigger datagrams.
class Receiver {
 public:
  Receiver() {
    fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(bind(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
    socklen_t len = sizeof sa;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&sa), &len);
    port_ = ntohs(sa.sin_port);
    int rcvbuf = 1 << 20;
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  }
  ~Receiver() { close(fd_); }

  config::Endpoint endpoint() const { return {"127.0.0.1", port_}; }

  // Everything that arrives until `quiet` passes without a datagram.
  std::vector<Pulse> drain(std::chrono::milliseconds quiet = 200ms) {
    std::vector<Pulse> out;
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(quiet.count())) <= 0) break;
      uint8_t buf[64];
      const ssize_t n = recv(fd_, buf, sizeof buf, 0);
      Pulse pulse;
      uint64_t t = 0;
      EXPECT_EQ(vc_trigger_dgram_decode(buf, static_cast<size_t>(n), &pulse.seq, &t), 0);
      pulse.t_ns = static_cast<int64_t>(t);
      out.push_back(pulse);
    }
    return out;
  }

 private:
  int fd_ = -1;
  uint16_t port_ = 0;
};

config::TriggerOptions udp_options(std::vector<config::Endpoint> targets) {
  config::TriggerOptions o;
  o.backend = config::TriggerBackend::Udp;
  o.udp.targets = std::move(targets);
  o.rt_priority = 0;  // tests share the machine: a normal thread
  return o;
}

TEST(UdpGenerator, SendsOneDatagramPerPulseWithConsecutiveSeqAndSaneTimes) {
  Receiver rx;
  auto gen = make_generator(udp_options({rx.endpoint()}));
  EXPECT_EQ(gen->backend(), "udp");
  EXPECT_THAT(gen->describe(), HasSubstr(rx.endpoint().str()));
  std::mutex m;
  std::vector<Pulse> observed;
  gen->set_observer([&](const Pulse& p) {
    std::lock_guard<std::mutex> lock(m);
    observed.push_back(p);
  });

  const int64_t before = static_cast<int64_t>(vc::monotonic_ns());
  gen->start(PulseTrain{200.0, 100.0, 25, 0});
  ASSERT_TRUE(gen->wait_done(10s));
  const int64_t after = static_cast<int64_t>(vc::monotonic_ns());
  EXPECT_FALSE(gen->running());
  EXPECT_EQ(gen->last_error(), "");
  EXPECT_EQ(gen->pulses_sent(), 25u);
  EXPECT_EQ(gen->stats().errors, 0u);
  EXPECT_EQ(gen->stats().pulses_sent, 25u);

  const std::vector<Pulse> got = rx.drain();
  ASSERT_EQ(got.size(), 25u);
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].seq, i);
    EXPECT_GT(got[i].t_ns, before);
    EXPECT_LT(got[i].t_ns, after);
    if (i > 0) {
      EXPECT_GT(got[i].t_ns, got[i - 1].t_ns);
    }
  }
  // The observer saw the very pulses that went on the wire.
  std::lock_guard<std::mutex> lock(m);
  ASSERT_EQ(observed.size(), got.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(observed[i].seq, got[i].seq);
    EXPECT_EQ(observed[i].t_ns, got[i].t_ns);
    EXPECT_GE(observed[i].lateness_ns, 0);
  }
}

TEST(UdpGenerator, EveryTargetGetsEveryPulse) {
  Receiver a, b, c;
  auto gen = make_generator(udp_options({a.endpoint(), b.endpoint(), c.endpoint()}));
  gen->start(PulseTrain{250.0, 50.0, 10, 100});
  ASSERT_TRUE(gen->wait_done(10s));
  for (Receiver* rx : {&a, &b, &c}) {
    const std::vector<Pulse> got = rx->drain();
    ASSERT_EQ(got.size(), 10u);
    for (size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].seq, 100 + i);  // first_seq honoured
  }
}

TEST(UdpGenerator, StopEndsAnOpenTrainAndStartAgainRestarts) {
  Receiver rx;
  auto gen = make_generator(udp_options({rx.endpoint()}));
  gen->start(500.0, 100.0);  // unlimited
  EXPECT_TRUE(gen->running());
  EXPECT_THROW(gen->start(500.0, 100.0), TriggerError);  // already running
  while (gen->pulses_sent() < 5) std::this_thread::sleep_for(1ms);
  gen->stop();
  gen->stop();  // idempotent
  EXPECT_FALSE(gen->running());
  const uint64_t sent = gen->pulses_sent();
  EXPECT_GE(sent, 5u);
  std::vector<Pulse> got = rx.drain();
  EXPECT_EQ(got.size(), sent);
  EXPECT_EQ(gen->pulses_sent(), sent);  // nothing after stop

  gen->start(PulseTrain{500.0, 100.0, 3, 0});
  ASSERT_TRUE(gen->wait_done(10s));
  got = rx.drain();
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0].seq, 0u);
  EXPECT_EQ(gen->pulses_sent(), 3u);  // counts are per train
}

TEST(UdpGenerator, RejectsABadTrainAndMissingTargets) {
  Receiver rx;
  auto gen = make_generator(udp_options({rx.endpoint()}));
  try {
    gen->start(0.0, 100.0);
    FAIL() << "rate 0 accepted";
  } catch (const TriggerError& e) {
    EXPECT_THAT(e.what(), HasSubstr("udp: rate"));
  }
  try {
    gen->start(100.0, 6000.0);  // wider than half the 10 ms period
    FAIL() << "too wide a pulse accepted";
  } catch (const TriggerError& e) {
    EXPECT_THAT(e.what(), HasSubstr("half the period"));
  }
  auto none = make_generator(udp_options({}));
  EXPECT_THROW(none->start(60.0, 100.0), TriggerError);
}

config::TriggerOptions gpiod_options(const std::string& chip, int line) {
  config::TriggerOptions o;
  o.backend = config::TriggerBackend::Gpiod;
  o.gpiod.chip = chip;
  o.gpiod.line_offset = line;
  o.rt_priority = 0;
  return o;
}

std::string start_error(Generator& gen) {
  try {
    gen.start(60.0, 100.0);
  } catch (const TriggerError& e) {
    return e.what();
  }
  gen.stop();
  return "";
}

TEST(GpiodGenerator, MissingChipIsAClearError) {
  auto gen = make_generator(gpiod_options("/dev/gpiochip-voxcap-absent", 18));
  EXPECT_EQ(gen->backend(), "gpiod");
  EXPECT_THAT(gen->describe(), HasSubstr("/dev/gpiochip-voxcap-absent line 18"));
  EXPECT_THAT(start_error(*gen), HasSubstr("gpiod: no GPIO chip at /dev/gpiochip-voxcap-absent"));
  EXPECT_FALSE(gen->running());
  EXPECT_EQ(gen->pulses_sent(), 0u);
}

TEST(GpiodGenerator, BareChipNamesLiveUnderDev) {
  auto gen = make_generator(gpiod_options("gpiochip-voxcap-absent", 3));
  EXPECT_THAT(start_error(*gen), HasSubstr("/dev/gpiochip-voxcap-absent"));
}

TEST(GpiodGenerator, AFileThatIsNoGpioChipIsAClearError) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "voxcap-not-a-gpiochip";
  std::ofstream(path) << "x";
  auto gen = make_generator(gpiod_options(path.string(), 0));
  EXPECT_THAT(start_error(*gen), HasSubstr("is not a GPIO chip"));
  std::filesystem::remove(path);
  auto dev_null = make_generator(gpiod_options("/dev/null", 0));
  EXPECT_THAT(start_error(*dev_null), HasSubstr("gpiod: /dev/null is not a GPIO chip"));
}

config::TriggerOptions ftdi_options() {
  config::TriggerOptions o;
  o.backend = config::TriggerBackend::Ftdi;
  o.rt_priority = 0;
  return o;
}

TEST(FtdiGenerator, NoDeviceIsAClearError) {
  config::TriggerOptions o = ftdi_options();
  // A serial no real box has, so the test means the same on a machine with a box plugged in.
  o.ftdi.serial = "voxcap-test-absent";
  auto gen = make_generator(o);
  EXPECT_EQ(gen->backend(), "ftdi");
  EXPECT_THAT(gen->describe(), HasSubstr("0403:6014"));
  const std::string error = start_error(*gen);
  EXPECT_THAT(error, HasSubstr("ftdi: no device 0403:6014 found"));
  EXPECT_THAT(error, HasSubstr("with serial voxcap-test-absent"));
  EXPECT_FALSE(gen->running());
}

TEST(FtdiGenerator, UnsupportedSampleRateIsRejectedBeforeTheDevice) {
  config::TriggerOptions o = ftdi_options();
  o.ftdi.sample_rate_hz = 5000;  // below the bit-bang clock range
  auto gen = make_generator(o);
  EXPECT_THAT(start_error(*gen), HasSubstr("ftdi: trigger.ftdi.sample_rate_hz: must be in [10000, 1000000]"));
}

TEST(PulseTrain, ValidatesAndComesFromOptions) {
  std::string why;
  EXPECT_TRUE((PulseTrain{60.0, 100.0, 0, 0}.valid(&why)));
  EXPECT_FALSE((PulseTrain{60.0, 0.0, 0, 0}.valid(&why)));
  EXPECT_THAT(why, HasSubstr("pulse width"));
  EXPECT_FALSE((PulseTrain{1001.0, 10.0, 0, 0}.valid(&why)));
  config::TriggerOptions o;
  o.rate_hz = 90;
  o.pulse_width_us = 250;
  const PulseTrain t = PulseTrain::from(o, 7);
  EXPECT_EQ(t.rate_hz, 90);
  EXPECT_EQ(t.pulse_width_us, 250);
  EXPECT_EQ(t.count, 7u);
}

}  // namespace
}  // namespace vc::trigger
