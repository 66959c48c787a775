// The viewer's HTTP + WebSocket server (Boost.Beast over Boost.Asio, header-only from Debian's
// libboost-dev), on ONE io thread of its own: nothing it does waits on the rig, and nothing the rig
// does waits on it. It serves
//   GET  /...         the page's static files from one folder (http_path.hpp: no traversal, bounded),
//   WS   /ws          the viewer's binary messages (encode.hpp, PROTOCOL.md); text messages from the page
//                     are control requests, handed to Hooks::control,
//   WS   /pose.json   the fitted pose as JSON text, one message per displayed frame (for scripts).
// Every client has a bounded send queue (messages and bytes): when a client reads too slowly the
// oldest queued live message is dropped and counted, so a paused browser costs at most that much memory
// and never slows a frame. Clients, connections, request headers, bodies and client messages are bounded;
// idle HTTP connections time out.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace vc::view {

using ClientId = uint64_t;
enum class Channel : uint8_t { Live, PoseJson };

struct ServerOptions {
  std::string bind = "127.0.0.1";     // numeric IPv4, or "any"
  uint16_t port = 8080;               // 0: a free port (port() says which)
  std::filesystem::path assets;       // the page's folder
  size_t max_clients = 8;             // WebSocket clients at once; one more gets 503
  size_t max_connections = 32;        // TCP connections at once (HTTP and WebSocket); more are closed at once
  size_t max_queue_messages = 64;     // per client
  size_t max_queue_bytes = 8u << 20;  // per client
  // SO_SNDBUF of a WebSocket connection (the kernel doubles it; 0: the kernel's autotuning, up to
  // net.ipv4.tcp_wmem's 4 MiB). Bounded, a paused browser fills it in seconds and its queue starts
  // dropping the oldest, instead of seconds of stale frames piling up in the kernel for it.
  size_t send_buffer_bytes = 256u << 10;
  size_t max_header_bytes = 8192;    // of an HTTP request; more: 431
  size_t max_body_bytes = 1024;      // of an HTTP request (the page sends none); more: 413
  size_t max_client_message = 4096;  // a WebSocket message from a client; more closes it
  double idle_timeout_s = 30;        // an HTTP connection with no request for this long is closed
  double tick_s = 0.5;               // Hooks::tick period

  bool valid(std::string* why) const;
};

// One WebSocket client's queue, while it is connected: how a paused browser shows (its dropped grows,
// its queued_bytes stays under max_queue_bytes).
struct ClientStats {
  ClientId id = 0;
  Channel channel = Channel::Live;
  uint16_t peer_port = 0;  // the client's TCP port (which browser tab, from the host's side)
  uint64_t sent = 0, dropped = 0;
  size_t queued_bytes = 0, queued_bytes_max = 0;
};

struct ServerStats {
  uint64_t clients = 0, clients_total = 0, clients_refused = 0, connections_refused = 0;
  uint64_t messages_sent = 0, messages_dropped = 0;  // dropped: the oldest live messages of slow clients
  uint64_t http_requests = 0, http_errors = 0;       // requests answered with 4xx/5xx
  uint64_t control_messages = 0;
  size_t queued_bytes_max = 0;          // the most bytes one client ever had queued
  std::vector<ClientStats> per_client;  // the WebSocket clients connected now, by id
};

class Server {
 public:
  struct Hooks {
    std::function<std::string(ClientId, Channel)> hello;           // first message to a client; "": none
    std::function<void(ClientId, std::string_view text)> control;  // a /ws client's text message
    std::function<void(ClientId)> closed;                          // a client went away
    std::function<void()> tick;                                    // every tick_s
  };
  // Hooks run on the io thread and must not block.
  Server(ServerOptions options, Hooks hooks);  // throws std::invalid_argument for invalid options
  ~Server();                                   // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  void start();  // binds and listens (throws std::runtime_error naming the address), starts the thread
  void stop();   // closes everything, joins the thread; idempotent
  uint16_t port() const;

  // Any thread; never blocks. Live binary messages go to every /ws client that is not replaying;
  // PoseJson text messages to every /pose.json client. Droppable: the oldest goes first when full.
  void broadcast(Channel channel, std::shared_ptr<const std::string> msg, bool binary);
  // One client (replay, replies). droppable false: kept even when the queue is full (small messages).
  void send(ClientId client, std::shared_ptr<const std::string> msg, bool binary, bool droppable);
  // A replaying client gets no live frames (it still gets Stats: `always`).
  void set_replaying(ClientId client, bool replaying);
  void broadcast_always(std::shared_ptr<const std::string> msg);  // to every /ws client (Stats)

  ServerStats stats() const;

  struct Impl;  // server.cpp (public only so that its session classes may name it)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace vc::view
