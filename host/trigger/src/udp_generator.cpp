// The emulated rig's trigger: each pulse is one trigger datagram (proto/SPEC.md: magic, version, seq,
// t_ns) sent to every edge's endpoint on loopback. t_ns is CLOCK_MONOTONIC just before the sends, which
// the edges can use directly because the emulated rig is one machine. A failed send is counted and
// logged (an edge that is not up yet must not stop the rig); only losing the socket is fatal.
#include "backends.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "voxcap/auth.h"
#include "voxcap/base/clock.hpp"
#include "voxcap/proto.hpp"

namespace vc::trigger::detail {

UdpGenerator::UdpGenerator(const config::TriggerOptions& options)
    : ScheduledGenerator(options), targets_(options.udp.targets) {
  if (!options.udp.key.empty()) {
    if (options.udp.key.size() != VC_AUTH_KEY_SIZE || vc_auth_init() < 0)
      throw TriggerError("udp: the rig key must be 32 bytes and libsodium must start");
    vc_auth_trigger_key(options.udp.key.data(), &mac_);
    // The counter starts at the wall clock in ns: a restarted host is still ahead of what every edge
    // took from its previous run, so its first datagrams are not taken for replays.
    mac_.counter = static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                             std::chrono::system_clock::now().time_since_epoch())
                                             .count());
    keyed_ = true;
  }
}

UdpGenerator::~UdpGenerator() {
  stop();
  if (fd_ >= 0) close(fd_);
}

std::string UdpGenerator::describe() const {
  std::string s = "udp";
  for (size_t i = 0; i < targets_.size(); ++i) s += (i == 0 ? " " : ", ") + targets_[i].str();
  return s;
}

void UdpGenerator::prepare(const PulseTrain& /*train*/) {
  if (targets_.empty()) throw TriggerError("udp: no targets configured (trigger.udp.targets)");
  if (fd_ >= 0) return;
  addrs_.clear();
  for (const config::Endpoint& t : targets_) {
    if (!t.is_loopback())
      throw TriggerError(
          fmt::format("udp: {} is not a loopback address; the udp trigger is for the "
                      "emulated rig on one machine",
                      t.str()));
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(t.port);
    const std::string host = t.host == "localhost" ? "127.0.0.1" : t.host;
    if (inet_pton(AF_INET, host.c_str(), &sa.sin_addr) != 1)
      throw TriggerError(fmt::format("udp: bad target address {}", t.str()));
    addrs_.push_back(sa);
  }
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw TriggerError(fmt::format("udp: cannot create a socket: {}", std::strerror(errno)));
  warned_.assign(addrs_.size(), false);
}

void UdpGenerator::leading_edge(Pulse& pulse) {
  pulse.t_ns = static_cast<int64_t>(vc::monotonic_ns());
  std::array<uint8_t, VC_TRIGGER_DGRAM_MAC_SIZE> dgram{};
  size_t dgram_size = VC_TRIGGER_DGRAM_SIZE;
  if (keyed_) {  // version 2: MAC and counter (proto/SPEC.md "Trigger datagram")
    vc_trigger_dgram_encode_mac(dgram.data(), pulse.seq, static_cast<uint64_t>(pulse.t_ns), &mac_);
    dgram_size = VC_TRIGGER_DGRAM_MAC_SIZE;
  } else {
    vc_trigger_dgram_encode(dgram.data(), pulse.seq, static_cast<uint64_t>(pulse.t_ns));
  }
  uint64_t failed = 0;
  for (size_t i = 0; i < addrs_.size(); ++i) {
    const ssize_t n = sendto(fd_, dgram.data(), dgram_size, 0, reinterpret_cast<const sockaddr*>(&addrs_[i]),
                             sizeof addrs_[i]);
    if (n == static_cast<ssize_t>(dgram_size)) continue;
    const int err = n < 0 ? errno : EMSGSIZE;
    if (err == EBADF || err == ENOTSOCK)
      throw TriggerError(fmt::format("udp: socket lost: {}", std::strerror(err)));
    ++failed;
    if (!warned_[i]) {
      warned_[i] = true;
      spdlog::warn("trigger: udp send to {} failed: {} (counted; further failures to it are not logged)",
                   targets_[i].str(), std::strerror(err));
    }
  }
  if (failed) update_stats([&](Stats& s) { s.errors += failed; });
}

}  // namespace vc::trigger::detail
