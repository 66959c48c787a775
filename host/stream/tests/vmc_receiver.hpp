// A VMC receiver for tests (what a Marionette such as EVMC4U gets): a UDP socket bound to 127.0.0.1 on
// an ephemeral port, read by a thread of its own; every datagram is decoded by liblo
// (lo_server_dispatch_data, through a dispatcher whose own socket is a unix one in a temp folder, so
// nothing listens on the network) into bundles of messages. Bounded: at most `keep` bundles are kept.
#pragma once

#include <lo/lo.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace vc::stream::testing {

struct OscMessage {
  std::string path;
  std::string types;           // OSC type tags ("sfffffff")
  std::vector<std::string> s;  // string arguments, in order
  std::vector<double> f;       // float arguments, in order
  std::vector<int> i;          // int32 arguments, in order
};
using OscBundle = std::vector<OscMessage>;

class VmcReceiver {
 public:
  explicit VmcReceiver(size_t keep = 100000) : keep_(keep) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (fd_ < 0) throw std::runtime_error("receiver: socket");
    const int big = 8 << 20;  // a slow test thread must not lose datagrams to a full buffer
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    socklen_t len = sizeof a;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("receiver: bind 127.0.0.1");
    port_ = ntohs(a.sin_port);
    char tmpl[] = "/tmp/voxcap-vmc-rx-XXXXXX";
    if (!::mkdtemp(tmpl)) throw std::runtime_error("receiver: mkdtemp");
    dir_ = tmpl;
    dispatcher_ = lo_server_new_with_proto((dir_ / "d").c_str(), LO_UNIX, nullptr);
    if (!dispatcher_) throw std::runtime_error("receiver: liblo dispatcher");
    lo_server_add_method(dispatcher_, nullptr, nullptr, &VmcReceiver::on_message, this);
    lo_server_add_bundle_handlers(dispatcher_, &VmcReceiver::on_start, &VmcReceiver::on_end, this);
    thread_ = std::thread([this] { run(); });
  }
  ~VmcReceiver() {
    stop_ = true;
    thread_.join();
    lo_server_free(dispatcher_);
    ::close(fd_);
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  VmcReceiver(const VmcReceiver&) = delete;
  VmcReceiver& operator=(const VmcReceiver&) = delete;

  uint16_t port() const { return port_; }
  std::string target() const { return "127.0.0.1:" + std::to_string(port_); }

  // Waits (bounded) until `n` bundles arrived; true when they did.
  bool wait_for(size_t n, int timeout_ms) const {
    for (int t = 0; t < timeout_ms; t += 10) {
      if (count() >= n) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return count() >= n;
  }
  size_t count() const {
    std::lock_guard<std::mutex> g(mu_);
    return bundles_.size();
  }
  std::vector<OscBundle> bundles() const {
    std::lock_guard<std::mutex> g(mu_);
    return bundles_;
  }
  uint64_t datagrams() const { return datagrams_; }
  uint64_t not_bundles() const { return not_bundles_; }  // datagrams that were a bare message or junk

 private:
  void run() {
    std::vector<char> buf(65536);
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
      if (n <= 0) continue;
      ++datagrams_;
      in_bundle_ = false;
      current_.clear();
      const bool bundle = n >= 8 && std::string(buf.data(), 7) == "#bundle";
      lo_server_dispatch_data(dispatcher_, buf.data(), static_cast<size_t>(n));
      if (!bundle) ++not_bundles_;
    }
  }
  // liblo's arguments sit where the OSC data puts them (4-byte aligned): read them by bytes, not
  // through the 8-byte union.
  static void add_arg(OscMessage& m, char type, const lo_arg* a) {
    const char* raw = reinterpret_cast<const char*>(a);
    if (type == 's') m.s.emplace_back(raw);
    if (type == 'f') {
      float v;
      std::memcpy(&v, raw, sizeof v);
      m.f.push_back(v);
    }
    if (type == 'd') {
      double v;
      std::memcpy(&v, raw, sizeof v);
      m.f.push_back(v);
    }
    if (type == 'i') {
      int32_t v;
      std::memcpy(&v, raw, sizeof v);
      m.i.push_back(v);
    }
  }
  static int on_message(const char* path, const char* types, lo_arg** argv, int argc, lo_message,
                        void* self) {
    auto* r = static_cast<VmcReceiver*>(self);
    OscMessage m;
    m.path = path;
    m.types = types ? types : "";
    for (int k = 0; k < argc; ++k) add_arg(m, m.types[static_cast<size_t>(k)], argv[k]);
    r->current_.push_back(std::move(m));
    return 0;
  }
  static int on_start(lo_timetag, void* self) {
    auto* r = static_cast<VmcReceiver*>(self);
    r->in_bundle_ = true;
    r->current_.clear();
    return 0;
  }
  static int on_end(void* self) {
    auto* r = static_cast<VmcReceiver*>(self);
    std::lock_guard<std::mutex> g(r->mu_);
    if (r->bundles_.size() < r->keep_) r->bundles_.push_back(r->current_);
    r->current_.clear();
    r->in_bundle_ = false;
    return 0;
  }

  size_t keep_;
  int fd_ = -1;
  uint16_t port_ = 0;
  std::filesystem::path dir_;
  lo_server dispatcher_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> datagrams_{0}, not_bundles_{0};
  bool in_bundle_ = false;
  OscBundle current_;
  mutable std::mutex mu_;
  std::vector<OscBundle> bundles_;
};

}  // namespace vc::stream::testing
