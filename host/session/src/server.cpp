#include "voxcap/session/server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/core.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include <sodium.h>

#include "voxcap/base/clock.hpp"

namespace vc::session {

bool ServerOptions::valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (heartbeat_interval_ms < 10) return fail("heartbeat_interval_ms: must be >= 10");
  if (heartbeat_timeout_ms <= heartbeat_interval_ms)
    return fail("heartbeat_timeout_ms: must exceed the interval");
  if (hello_timeout_ms < 10) return fail("hello_timeout_ms: must be >= 10");
  if (max_out_bytes < 4096) return fail("max_out_bytes: must be >= 4096");
  if (max_prehello_connections == 0) return fail("max_prehello_connections: must be >= 1");
  if (max_prehello_payload < 128 || max_prehello_payload > VC_PROTO_MAX_PAYLOAD)
    return fail("max_prehello_payload: must be in 128..VC_PROTO_MAX_PAYLOAD");
  if (poll_interval_ms < 1 || poll_interval_ms > 1000) return fail("poll_interval_ms: must be in 1..1000");
  if (!key.empty() && key.size() != VC_AUTH_KEY_SIZE) return fail("key: must be 32 bytes (or none)");
  return true;
}

struct Server::Conn {
  int fd = -1;
  ConnId id = 0;
  std::string peer;
  vc_decoder* dec = nullptr;
  bool hello = false;
  uint16_t node_id = 0;
  uint64_t created_ns = 0, last_rx_ns = 0, last_hb_ns = 0;
  std::deque<std::vector<uint8_t>> out;  // under mu_
  size_t out_off = 0, out_bytes = 0;     // under mu_
  bool overflow = false;                 // under mu_
  std::string closing;                   // under mu_: close after flushing
  ConnectionStats st;
  // 2.3, keyed rigs: HELLO (kept until the proof) -> AUTH challenge -> our response -> AUTH proof.
  enum class Auth { none, wait_challenge, wait_proof, done } auth = Auth::none;
  std::vector<uint8_t> hello_raw;
  uint8_t nonce_node[VC_AUTH_NONCE_SIZE] = {}, nonce_host[VC_AUTH_NONCE_SIZE] = {};
  vc_mac tx{};  // host -> node, under mu_
  ~Conn() {
    sodium_memzero(&tx, sizeof tx);
    vc_decoder_free(dec);
    if (fd >= 0) ::close(fd);
  }
};

Server::Server(ServerOptions options, Handler& handler, log::Fn log)
    : opt_(std::move(options)), handler_(handler), log_(log::or_spdlog(std::move(log), "voxcap-host")) {
  std::string why;
  if (!opt_.valid(&why)) throw std::invalid_argument("session server: " + why);
  if (!opt_.key.empty() && vc_auth_init() < 0)
    throw std::runtime_error("session server: libsodium failed to start");
}

Server::~Server() {
  stop();
}

void Server::start() {
  if (running_) return;
  listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_fd_ < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  int one = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(opt_.port);
  std::string addr = opt_.listen == "any" ? "0.0.0.0" : opt_.listen;
  if (inet_pton(AF_INET, addr.c_str(), &a.sin_addr) != 1)
    throw std::runtime_error(fmt::format("listen address '{}' is not an IPv4 address", opt_.listen));
  if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) < 0 || listen(listen_fd_, 16) < 0) {
    int e = errno;
    ::close(listen_fd_);
    listen_fd_ = -1;
    throw std::runtime_error(fmt::format("cannot listen on {}:{}: {}", addr, opt_.port, std::strerror(e)));
  }
  socklen_t len = sizeof(a);
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void Server::stop() {
  if (!running_.exchange(false)) return;
  uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof(one)) < 0) {
  }
  thread_.join();
  {
    std::lock_guard<std::mutex> g(mu_);
    conns_.clear();
  }
  ::close(listen_fd_);
  ::close(wake_fd_);
  listen_fd_ = wake_fd_ = -1;
}

bool Server::send(ConnId id, const uint8_t* data, size_t len) {
  std::lock_guard<std::mutex> g(mu_);
  auto it = conns_.find(id);
  if (it == conns_.end() || !it->second->closing.empty()) return false;
  Conn& c = *it->second;
  queue_locked(c, data, len);
  uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof(one)) < 0) {
  }
  return !c.overflow;
}

bool Server::drain(int timeout_ms) {
  uint64_t end = monotonic_ns() + static_cast<uint64_t>(timeout_ms) * 1'000'000u;
  for (;;) {
    {
      std::lock_guard<std::mutex> g(mu_);
      bool empty = true;
      for (const auto& [id, c] : conns_) empty = empty && c->out.empty();
      if (empty || !running_) return empty;
    }
    if (monotonic_ns() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void Server::close(ConnId id, const std::string& reason) {
  std::lock_guard<std::mutex> g(mu_);
  auto it = conns_.find(id);
  if (it != conns_.end() && it->second->closing.empty())
    it->second->closing = reason.empty() ? "closed" : reason;
  uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof(one)) < 0) {
  }
}

void Server::queue_locked(Conn& c, const uint8_t* data, size_t len) {
  size_t sealed_len = c.st.authenticated ? len + VC_AUTH_TRAILER_SIZE : len;
  if (c.out_bytes + sealed_len > opt_.max_out_bytes) {
    c.overflow = true;  // nothing sealed: the counter moves only with what is sent
    return;
  }
  std::vector<uint8_t>& b = c.out.emplace_back(data, data + len);
  if (c.st.authenticated) {
    b.resize(sealed_len);
    size_t out = 0;
    if (vc_mac_seal(&c.tx, b.data(), len, b.size(), &out) < 0) {  // not one whole message: a caller bug
      c.out.pop_back();
      log(log::Level::err,
          fmt::format("connection {}: refusing to send {} bytes that are not one message", c.id, len));
      return;
    }
  }
  c.out_bytes += sealed_len;
}

bool Server::authenticated(ConnId id) const {
  std::lock_guard<std::mutex> g(mu_);
  auto it = conns_.find(id);
  return it != conns_.end() && it->second->st.authenticated;
}

uint64_t Server::silent_ns(ConnId id, uint64_t now_ns) const {
  std::lock_guard<std::mutex> g(mu_);
  auto it = conns_.find(id);
  if (it == conns_.end()) return 0;
  uint64_t last = it->second->last_rx_ns;
  return now_ns > last ? now_ns - last : 0;
}

std::vector<ConnectionStats> Server::connections() const {
  std::lock_guard<std::mutex> g(mu_);
  std::vector<ConnectionStats> v;
  for (const auto& [id, c] : conns_) v.push_back(c->st);
  return v;
}

ServerStats Server::stats() const {
  std::lock_guard<std::mutex> g(mu_);
  return stats_;
}

void Server::drop(Conn& c, const std::string& reason, bool notify) {
  log(c.hello ? log::Level::warn : log::Level::info,
      fmt::format("connection {} ({}{}) dropped: {}", c.id, c.peer,
                  c.hello ? fmt::format(", node {}", c.node_id) : "", reason));
  if (notify && c.hello) handler_.on_disconnect(c.id, reason);
  std::lock_guard<std::mutex> g(mu_);
  stats_.closed++;
  conns_.erase(c.id);
}

static void send_error_now(int fd, uint16_t code, uint16_t severity, const std::string& text) {
  std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 32 + text.size());
  size_t len = 0;
  vc_header hdr{};
  vc_error e{};
  e.code = code;
  e.severity = severity;
  e.text_len = static_cast<uint16_t>(std::min<size_t>(text.size(), VC_PROTO_MAX_ERROR_TEXT));
  e.text = text.data();
  if (vc_encode_error(buf.data(), buf.size(), &len, &hdr, &e) == 0) {
    if (::send(fd, buf.data(), len, MSG_NOSIGNAL | MSG_DONTWAIT) < 0) {
    }
  }
}

void Server::error_to(Conn& c, uint16_t code, uint16_t severity, const std::string& text) {
  if (!c.st.authenticated) {
    send_error_now(c.fd, code, severity, text);
    return;
  }
  std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 32 + text.size());
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = c.node_id;
  vc_error e{};
  e.code = code;
  e.severity = severity;
  e.text_len = static_cast<uint16_t>(std::min<size_t>(text.size(), VC_PROTO_MAX_ERROR_TEXT));
  e.text = text.data();
  if (vc_encode_error(buf.data(), buf.size(), &len, &hdr, &e) == 0) {
    std::lock_guard<std::mutex> g(mu_);
    queue_locked(c, buf.data(), len);
  }
}

bool Server::refuse_auth(Conn& c, const std::string& why) {
  log(log::Level::warn, fmt::format("connection {} ({}): refused: {}", c.id, c.peer, why));
  send_error_now(c.fd, VC_ERR_AUTH, VC_SEVERITY_FATAL, why);
  std::lock_guard<std::mutex> g(mu_);
  stats_.auth_refused++;
  stats_.hello_rejected++;
  c.closing = "authentication: " + why;
  return false;
}

bool Server::accept_hello(Conn& c, const vc_msg& m) {
  std::string why = handler_.on_hello(c.id, m, c.peer);
  if (!why.empty()) {
    error_to(c, VC_ERR_STATE, VC_SEVERITY_FATAL, why);
    std::lock_guard<std::mutex> g(mu_);
    stats_.hello_rejected++;
    c.closing = "HELLO rejected: " + why;
    return false;
  }
  c.hello = true;
  vc_decoder_set_max_payload(c.dec, 0);  // a node now: the protocol's maximum
  c.node_id = m.u.hello.node_id;
  std::lock_guard<std::mutex> g(mu_);
  c.st.hello = true;
  c.st.node_id = c.node_id;
  return true;
}

bool Server::handle_auth(Conn& c, const vc_msg& m) {
  const uint8_t* key = opt_.key.data();
  if (m.hdr.type != VC_MSG_AUTH)
    return refuse_auth(
        c, fmt::format("node {} sent {} before proving the key", c.node_id,
                       vc_msg_type_name(m.hdr.type) ? vc_msg_type_name(m.hdr.type) : "an unknown type"));
  const vc_auth_msg& a = m.u.auth;
  if (c.auth == Conn::Auth::wait_challenge) {
    if (a.step != VC_AUTH_CHALLENGE) return refuse_auth(c, "the node's first AUTH was not its challenge");
    std::memcpy(c.nonce_node, a.nonce, VC_AUTH_NONCE_SIZE);
    vc_auth_random(c.nonce_host, VC_AUTH_NONCE_SIZE);
    vc_auth_msg r{};
    r.step = VC_AUTH_RESPONSE;
    std::memcpy(r.nonce, c.nonce_host, VC_AUTH_NONCE_SIZE);
    vc_auth_prove(r.proof, key, VC_AUTH_ROLE_HOST, c.node_id, c.nonce_node, c.nonce_host);
    uint8_t buf[VC_PROTO_HEADER_SIZE + 128];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = c.node_id;
    if (vc_encode_auth(buf, sizeof buf, &len, &hdr, &r) < 0) return refuse_auth(c, "cannot encode AUTH");
    std::lock_guard<std::mutex> g(mu_);
    queue_locked(c, buf, len);
    c.auth = Conn::Auth::wait_proof;
    return true;
  }
  if (a.step != VC_AUTH_PROOF ||
      !vc_auth_verify(a.proof, key, VC_AUTH_ROLE_NODE, c.node_id, c.nonce_node, c.nonce_host))
    return refuse_auth(c, fmt::format("node {} did not prove the rig key", c.node_id));
  vc_mac n2h{}, h2n{};
  vc_auth_session(key, c.node_id, c.nonce_node, c.nonce_host, &n2h, &h2n);
  vc_decoder_set_mac(c.dec, &n2h);  // from the next message on
  sodium_memzero(&n2h, sizeof n2h);
  {
    std::lock_guard<std::mutex> g(mu_);
    c.tx = h2n;
    c.st.authenticated = true;
  }
  sodium_memzero(&h2n, sizeof h2n);
  c.auth = Conn::Auth::done;
  vc_msg hello{};
  size_t used = 0;
  if (vc_msg_decode(c.hello_raw.data(), c.hello_raw.size(), 0, &hello, &used, nullptr) != 1)
    return refuse_auth(c, "the kept HELLO no longer decodes");
  log(log::Level::info,
      fmt::format("connection {} ({}): node {} proved the rig key", c.id, c.peer, c.node_id));
  return accept_hello(c, hello);
}

void Server::handle_readable(Conn& c, uint64_t now_ns) {
  uint8_t chunk[65536];
  for (int rounds = 0; rounds < 16; rounds++) {  // bounded per poll so one node cannot starve the rest
    ssize_t n = recv(c.fd, chunk, sizeof(chunk), MSG_DONTWAIT);
    if (n == 0) {
      int rc = vc_decoder_finish(c.dec);
      drop(c, rc < 0 ? "closed inside a message (truncated)" : "closed by the edge", true);
      return;
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return;
      drop(c, std::string("receive failed: ") + std::strerror(errno), true);
      return;
    }
    c.last_rx_ns = now_ns;
    c.st.bytes_in += static_cast<uint64_t>(n);
    size_t used = 0;
    for (size_t off = 0; off < static_cast<size_t>(n); off += used) {
      int rc = vc_decoder_feed(c.dec, chunk + off, static_cast<size_t>(n) - off, &used);
      if (rc < 0) {
        const vc_proto_diag* d = vc_decoder_diag(c.dec);
        std::lock_guard<std::mutex> g(mu_);
        stats_.decode_drops++;
        c.closing = fmt::format("{} at byte {}: {}", vc_proto_error_name(rc), d->offset, d->detail);
        return;
      }
      vc_msg m;
      while ((rc = vc_decoder_next(c.dec, &m)) != 0) {
        if (rc < 0) {
          const vc_proto_diag* d = vc_decoder_diag(c.dec);
          std::string why = fmt::format("{} at byte {}: {}", vc_proto_error_name(rc), d->offset, d->detail);
          c.st.rejected++;
          if (vc_proto_error_is_fatal(rc)) {
            std::lock_guard<std::mutex> g(mu_);
            stats_.decode_drops++;
            c.closing = why;
            return;
          }
          if (rc == VC_PROTO_EMAC || rc == VC_PROTO_EREPLAY || rc == VC_PROTO_EORDER) {
            bool close_it = false;
            {
              std::lock_guard<std::mutex> g(mu_);
              uint64_t& count = rc == VC_PROTO_EMAC      ? c.st.forged
                                : rc == VC_PROTO_EREPLAY ? c.st.replayed
                                                         : c.st.reordered;
              count++;
              stats_.mac_rejected++;
              (rc == VC_PROTO_EMAC      ? stats_.mac_forged
               : rc == VC_PROTO_EREPLAY ? stats_.mac_replayed
                                        : stats_.mac_reordered)++;
              if (!c.hello) stats_.mac_unidentified++;
              uint64_t total = c.st.forged + c.st.replayed + c.st.reordered;
              log(log::Level::warn,
                  fmt::format("connection {} (node {}): dropped a message: {} ({} {} so far)", c.id,
                              c.node_id, why, count,
                              rc == VC_PROTO_EMAC      ? "forged"
                              : rc == VC_PROTO_EREPLAY ? "replayed"
                                                       : "reordered"));
              if (total >= VC_AUTH_MAX_REJECTS) {
                c.closing = fmt::format("{} messages failed their MAC", total);
                close_it = true;
              }
            }
            // Outside mu_: the handler may send (Server::send takes mu_).
            if (c.hello) handler_.on_mac_rejected(c.id, c.node_id, rc);
            if (close_it) return;
            continue;
          }
          log(log::Level::warn, fmt::format("connection {}: rejected a message: {}", c.id, why));
          error_to(c, VC_ERR_PROTOCOL, VC_SEVERITY_ERROR, why);
          continue;
        }
        c.st.messages_in++;
        if (!c.hello) {
          if (c.auth != Conn::Auth::none) {
            if (!handle_auth(c, m)) return;
            continue;
          }
          if (m.hdr.type != VC_MSG_HELLO) {
            std::string why =
                fmt::format("first message was {} instead of HELLO",
                            vc_msg_type_name(m.hdr.type) ? vc_msg_type_name(m.hdr.type) : "unknown");
            send_error_now(c.fd, VC_ERR_STATE, VC_SEVERITY_FATAL, why);
            std::lock_guard<std::mutex> g(mu_);
            stats_.hello_rejected++;
            c.closing = why;
            return;
          }
          const bool offers_key = (m.u.hello.capabilities & VC_CAP_AUTH) != 0;
          if (opt_.key.empty() != !offers_key) {
            if (!refuse_auth(c,
                             opt_.key.empty()
                                 ? fmt::format("node {} holds a key but this rig has none: name the same key "
                                               "file in rig.toml (key = ...)",
                                               m.u.hello.node_id)
                                 : fmt::format("this rig is keyed and node {} offers no key (a keyless or "
                                               "pre-2.3 voxcap-edge): give it the rig's key file",
                                               m.u.hello.node_id)))
              return;
          }
          if (offers_key) {  // the HELLO waits for the proof; the handler sees it only then
            c.hello_raw.assign(m.payload - VC_PROTO_HEADER_SIZE, m.payload + m.hdr.payload_len);
            c.node_id = m.u.hello.node_id;
            c.auth = Conn::Auth::wait_challenge;
            continue;
          }
          if (!accept_hello(c, m)) return;
          continue;
        }
        handler_.on_message(c.id, m, now_ns);
      }
    }
  }
}

void Server::flush(Conn& c) {
  std::lock_guard<std::mutex> g(mu_);
  while (!c.out.empty()) {
    const std::vector<uint8_t>& b = c.out.front();
    ssize_t n = ::send(c.fd, b.data() + c.out_off, b.size() - c.out_off, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0) return;  // EAGAIN or an error that the next recv/poll reports
    c.out_off += static_cast<size_t>(n);
    c.st.bytes_out += static_cast<uint64_t>(n);
    if (c.out_off < b.size()) return;
    c.out_bytes -= b.size();
    c.out.pop_front();
    c.out_off = 0;
  }
}

void Server::run() {
  std::vector<pollfd> fds;
  std::vector<ConnId> ids;
  uint64_t next_hb = monotonic_ns();
  while (running_) {
    fds.clear();
    ids.clear();
    fds.push_back({listen_fd_, POLLIN, 0});
    fds.push_back({wake_fd_, POLLIN, 0});
    {
      std::lock_guard<std::mutex> g(mu_);
      for (auto& [id, c] : conns_) {
        fds.push_back({c->fd, static_cast<short>(POLLIN | (c->out.empty() ? 0 : POLLOUT)), 0});
        ids.push_back(id);
      }
    }
    poll(fds.data(), fds.size(), opt_.poll_interval_ms);
    uint64_t now = monotonic_ns();
    if (fds[1].revents & POLLIN) {
      uint64_t v;
      if (read(wake_fd_, &v, sizeof(v)) < 0) {
      }
    }
    if (fds[0].revents & POLLIN) {
      for (int k = 0; k < 8; k++) {
        sockaddr_in peer{};
        socklen_t pl = sizeof(peer);
        int fd = accept4(listen_fd_, reinterpret_cast<sockaddr*>(&peer), &pl, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (fd < 0) break;
        int one = 1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        auto c = std::make_unique<Conn>();
        c->fd = fd;
        char ip[INET_ADDRSTRLEN] = "?";
        inet_ntop(AF_INET, &peer.sin_addr, ip, sizeof(ip));
        c->peer = fmt::format("{}:{}", ip, ntohs(peer.sin_port));
        char why[128];
        if (vc_decoder_new(opt_.max_prehello_payload, &c->dec, why, sizeof(why)) < 0) {
          log(log::Level::warn, fmt::format("connection from {} refused: {}", c->peer, why));
          continue;  // ~Conn closes the socket
        }
        c->created_ns = c->last_rx_ns = now;
        std::lock_guard<std::mutex> g(mu_);
        // At most max_prehello_connections strangers: the oldest goes (a real node says HELLO at once,
        // so it is never the oldest for long).
        size_t strangers = 0;
        Conn* oldest = nullptr;
        for (auto& [id, x] : conns_) {
          if (x->hello || !x->closing.empty()) continue;
          strangers++;
          if (!oldest) oldest = x.get();  // ids grow: the first is the oldest
        }
        if (oldest && strangers >= opt_.max_prehello_connections) {
          oldest->closing =
              fmt::format("evicted: more than {} connections without HELLO", opt_.max_prehello_connections);
          stats_.prehello_evicted++;
        }
        c->id = next_id_++;
        c->st.id = c->id;
        c->st.peer = c->peer;
        stats_.accepted++;
        conns_.emplace(c->id, std::move(c));
      }
    }
    bool hb = now >= next_hb;
    if (hb) next_hb = now + static_cast<uint64_t>(opt_.heartbeat_interval_ms) * 1'000'000u;
    for (size_t i = 0; i < ids.size(); i++) {
      Conn* c = nullptr;
      {
        std::lock_guard<std::mutex> g(mu_);
        auto it = conns_.find(ids[i]);
        if (it == conns_.end()) continue;
        c = it->second.get();
      }
      short re = fds[i + 2].revents;
      if (re & POLLIN) {
        handle_readable(*c, now);
        std::lock_guard<std::mutex> g(mu_);
        if (!conns_.count(ids[i])) continue;  // dropped inside
      } else if (re & (POLLERR | POLLHUP)) {
        drop(*c, "connection reset", true);
        continue;
      }
      std::string closing, timeout;
      bool overflow;
      {
        std::lock_guard<std::mutex> g(mu_);
        closing = c->closing;
        overflow = c->overflow;
      }
      if (overflow) {
        {
          std::lock_guard<std::mutex> g(mu_);
          stats_.overflow_drops++;
        }
        drop(*c, "outgoing queue overflow: the edge stopped reading", true);
        continue;
      }
      if (!c->hello && closing.empty() &&
          now - c->created_ns > static_cast<uint64_t>(opt_.hello_timeout_ms) * 1'000'000u) {
        closing = "no HELLO in time";
        std::lock_guard<std::mutex> g(mu_);
        stats_.prehello_timeouts++;
      }
      if (c->hello && now - c->last_rx_ns > static_cast<uint64_t>(opt_.heartbeat_timeout_ms) * 1'000'000u) {
        timeout = fmt::format("silent for {} ms (heartbeat timeout)", (now - c->last_rx_ns) / 1'000'000u);
        std::lock_guard<std::mutex> g(mu_);
        stats_.timeouts++;
      }
      if (!timeout.empty()) {
        drop(*c, timeout, true);
        continue;
      }
      if (hb && c->hello) {
        uint8_t buf[VC_PROTO_HEADER_SIZE + 32];
        size_t len = 0;
        vc_header hdr{};
        vc_heartbeat h{now, VC_STATE_HOST};
        if (vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &h) == 0) {
          std::lock_guard<std::mutex> g(mu_);
          if (c->out_bytes + len + VC_AUTH_TRAILER_SIZE <= opt_.max_out_bytes) queue_locked(*c, buf, len);
        }
      }
      flush(*c);
      if (!closing.empty()) {
        drop(*c, closing, true);
        continue;
      }
    }
    handler_.on_tick(now);
  }
}

}  // namespace vc::session
