// The host's side of the edge links: a TCP server that accepts edge connections, decodes their
// messages (any chunking, proto/'s streaming decoder), and hands them to a Handler on its one thread.
//
// Per connection: the first message must be HELLO, which the handler accepts or rejects (the reason
// goes back as a fatal ERROR and the connection is closed). Afterwards every message goes to
// on_message. A connection is dropped — with the reason logged and given to on_disconnect, the others
// unaffected — when its bytes cannot be decoded (bad magic, CRC, oversize, truncated at EOF), when it
// has said nothing for heartbeat_timeout, when its outgoing queue overflows (the edge stopped
// reading), or when it closes. A decodable but invalid message (non-fatal decoder error) is answered
// with ERROR and skipped. The server sends HEARTBEAT to every connection each heartbeat_interval.
//
// Before its HELLO is accepted a connection is a stranger's, and bounded (issue #13: 100 connections
// sending 8 MiB each took the host to 1 GB): at most max_prehello_connections of them are open (a new
// one evicts the oldest), each is dropped after hello_timeout_ms, and its decoder takes a first message
// of at most max_prehello_payload bytes (a message that declares more is dropped after its 40-byte
// header, nothing buffered). After HELLO the protocol's maximum applies (VC_PROTO_MAX_PAYLOAD).
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "voxcap/auth.h"
#include "voxcap/base/log.hpp"
#include "voxcap/proto.h"

namespace vc::session {

using ConnId = uint64_t;

class Handler {
 public:
  virtual ~Handler() = default;
  // HELLO arrived on conn. Return "" to accept it, or why not (sent to the edge, then closed).
  virtual std::string on_hello(ConnId conn, const vc_msg& hello, const std::string& peer) = 0;
  // Any later message; views in msg are valid during the call only. t_rx_ns: CLOCK_MONOTONIC.
  virtual void on_message(ConnId conn, const vc_msg& msg, uint64_t t_rx_ns) = 0;
  // The connection is gone (after an accepted HELLO only).
  virtual void on_disconnect(ConnId conn, const std::string& reason) = 0;
  // Called on the server thread about every poll_interval (for deadlines and timers).
  virtual void on_tick(uint64_t now_ns) { (void)now_ns; }
  // A message on conn, whose HELLO for node_id was accepted, was dropped by its MAC (2.3):
  // VC_PROTO_EMAC (forged), VC_PROTO_EREPLAY (replayed) or VC_PROTO_EORDER (reordered). The server
  // has counted and logged it; this is for the handler's per-node counts.
  virtual void on_mac_rejected(ConnId conn, uint16_t node_id, int code) {
    (void)conn;
    (void)node_id;
    (void)code;
  }
};

struct ServerOptions {
  std::string listen = "127.0.0.1";  // IPv4 address, or "any"
  uint16_t port = 7600;              // 0: any free port (see Server::port())
  int heartbeat_interval_ms = 250;
  int heartbeat_timeout_ms = 2000;
  int hello_timeout_ms = 2000;           // a connection that does not say HELLO in time is dropped
  size_t max_prehello_connections = 16;  // open before HELLO; a new one evicts the oldest
  size_t max_prehello_payload = VC_PROTO_MAX_HELLO_PAYLOAD;  // bytes of the first message's payload
  size_t max_out_bytes = 16u << 20;                          // per-connection outgoing queue
  int poll_interval_ms = 5;
  std::vector<uint8_t> key;  // the rig key (VC_AUTH_KEY_SIZE bytes) or empty: keyless (loopback rigs only)

  bool valid(std::string* why) const;
};

struct ConnectionStats {
  ConnId id = 0;
  uint16_t node_id = 0;
  std::string peer;
  bool hello = false;
  uint64_t bytes_in = 0, bytes_out = 0, messages_in = 0, rejected = 0;
  bool authenticated = false;                        // proved the rig key (2.3)
  uint64_t forged = 0, replayed = 0, reordered = 0;  // messages dropped by their MAC (2.3)
};

struct ServerStats {
  uint64_t accepted = 0, closed = 0, hello_rejected = 0, decode_drops = 0, timeouts = 0, overflow_drops = 0;
  uint64_t prehello_evicted = 0;   // connections without HELLO closed to make room (max_prehello_connections)
  uint64_t prehello_timeouts = 0;  // connections without HELLO in hello_timeout_ms
  uint64_t auth_refused = 0;       // keyless HELLOs on a keyed rig, failed or missing proofs
  uint64_t mac_rejected = 0;       // messages dropped by their MAC (all connections)
  // mac_rejected by reason, all connections: a bad tag or none, a counter used before, one ahead.
  uint64_t mac_forged = 0, mac_replayed = 0, mac_reordered = 0;
  // mac_rejected on connections that were no node's yet (no HELLO accepted): no handler sees those.
  uint64_t mac_unidentified = 0;
};

class Server {
 public:
  // Lines go to log; without one to spdlog as "voxcap-host: ...".
  Server(ServerOptions options, Handler& handler, log::Fn log = {});
  ~Server();  // stops
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and starts the thread; throws std::runtime_error (address in use, ...).
  void start();
  void stop();
  uint16_t port() const { return port_; }

  // Queues bytes for a connection (thread-safe; from the handler too). false if it is gone.
  bool send(ConnId conn, const uint8_t* data, size_t len);
  bool send(ConnId conn, const std::vector<uint8_t>& bytes) { return send(conn, bytes.data(), bytes.size()); }
  // Waits until every connection's queued bytes were written (or timeout_ms passed); true if all were.
  bool drain(int timeout_ms);
  // Closes a connection after flushing what is queued (thread-safe).
  void close(ConnId conn, const std::string& reason);

  // Whether conn proved the rig key, and how long ago it last sent anything (ns); false / 0 if gone.
  bool authenticated(ConnId conn) const;
  uint64_t silent_ns(ConnId conn, uint64_t now_ns) const;

  std::vector<ConnectionStats> connections() const;
  ServerStats stats() const;

 private:
  struct Conn;
  void run();
  void drop(Conn& c, const std::string& reason, bool notify);
  void handle_readable(Conn& c, uint64_t now_ns);
  void flush(Conn& c);
  void queue_locked(Conn& c, const uint8_t* data, size_t len);  // seals when authenticated; mu_ held
  bool handle_auth(Conn& c, const vc_msg& m);                   // false: the connection is closing
  bool accept_hello(Conn& c, const vc_msg& hello);              // false: refused, closing
  bool refuse_auth(Conn& c, const std::string& why);            // always false
  void error_to(Conn& c, uint16_t code, uint16_t severity, const std::string& text);
  void log(log::Level level, const std::string& line) const { log_(level, line); }

  ServerOptions opt_;
  Handler& handler_;
  log::Fn log_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  uint16_t port_ = 0;
  std::thread thread_;
  std::atomic<bool> running_{false};
  mutable std::mutex mu_;  // guards conns_' out queues and closing flags, stats_
  std::map<ConnId, std::unique_ptr<Conn>> conns_;
  ConnId next_id_ = 1;
  ServerStats stats_;
};

}  // namespace vc::session
