#include "voxcap/view/server.hpp"

#include <algorithm>
#include <atomic>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility>: gcc 12's C++20
// headers no longer bring it in through <memory> (clang's libstdc++ build happens to).
#include <utility>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "voxcap/view/http_path.hpp"

namespace vc::view {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using error_code = beast::error_code;

bool ServerOptions::valid(std::string* why) const {
  auto fail = [&](std::string s) {
    if (why) *why = std::move(s);
    return false;
  };
  error_code ec;
  if (bind != "any") {
    net::ip::make_address_v4(bind, ec);
    if (ec) return fail(fmt::format("viewer bind: not a numeric IPv4 address: \"{}\"", bind));
  }
  if (max_clients < 1 || max_clients > 1024) return fail("viewer: max_clients must be 1..1024");
  if (max_connections < max_clients) return fail("viewer: max_connections must be >= max_clients");
  if (max_queue_messages < 2 || max_queue_bytes < 4096) return fail("viewer: queue too small");
  if (send_buffer_bytes != 0 && (send_buffer_bytes < 4096 || send_buffer_bytes > (64u << 20)))
    return fail("viewer: send_buffer_bytes must be 0 or 4 KiB..64 MiB");
  if (max_header_bytes < 512 || max_client_message < 64) return fail("viewer: limits too small");
  if (!(idle_timeout_s > 0) || !(tick_s > 0)) return fail("viewer: timeouts must be > 0");
  return true;
}

namespace {

struct Out {
  std::shared_ptr<const std::string> msg;
  bool binary = true;
  bool droppable = true;
};

std::chrono::milliseconds ms(double s) {
  return std::chrono::milliseconds(static_cast<int64_t>(s * 1000));
}

}  // namespace

class WsSession;

struct Server::Impl {
  ServerOptions opt;
  Hooks hooks;
  // Destroyed first (~Impl): the handlers it still holds own sessions, which use the members below.
  std::unique_ptr<net::io_context> ioc = std::make_unique<net::io_context>(1);
  std::optional<tcp::acceptor> acceptor;
  std::optional<net::steady_timer> ticker;
  std::thread thread;
  std::atomic<bool> running{false};
  uint16_t port = 0;
  // io thread only
  std::map<ClientId, std::weak_ptr<WsSession>> clients;
  ClientId next_id = 1;
  std::atomic<size_t> connections{0};
  // any thread
  mutable std::mutex stats_mu;
  ServerStats stats;                              // per_client filled by stats() from clients_stats
  std::map<ClientId, ClientStats> clients_stats;  // the connected WebSocket clients' queues

  void count(uint64_t ServerStats::*field, uint64_t n = 1) {
    std::lock_guard<std::mutex> lock(stats_mu);
    stats.*field += n;
  }
  void accept();
  void tick();
  ~Impl() {
    acceptor.reset();
    ticker.reset();
    clients.clear();
    ioc.reset();
  }
};

// Counts a TCP connection for as long as it lives (HTTP, then maybe WebSocket).
struct ConnectionSlot {
  std::atomic<size_t>* n;
  explicit ConnectionSlot(std::atomic<size_t>* c) : n(c) { ++*n; }
  ~ConnectionSlot() { --*n; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Server::Impl& impl, tcp::socket socket, Channel ch, std::unique_ptr<ConnectionSlot> slot)
      : impl_(impl), ws_(std::move(socket)), ch_(ch), slot_(std::move(slot)) {}

  void run(const http::request<http::string_body>& req) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(impl_.opt.max_client_message);
    ws_.async_accept(req, [self = shared_from_this()](error_code ec) { self->on_accept(ec); });
  }

  void enqueue(Out out) {
    if (closed_) return;
    q_bytes_ += out.msg->size();
    q_.push_back(std::move(out));
    // Drop the oldest droppable message (never the one being written) until within bounds.
    uint64_t dropped = 0;
    while (q_.size() > impl_.opt.max_queue_messages || q_bytes_ > impl_.opt.max_queue_bytes) {
      auto it = q_.begin() + (writing_ ? 1 : 0);
      while (it != q_.end() && !it->droppable) ++it;
      if (it == q_.end()) break;
      q_bytes_ -= it->msg->size();
      q_.erase(it);
      dropped++;
    }
    {
      std::lock_guard<std::mutex> lock(impl_.stats_mu);
      impl_.stats.messages_dropped += dropped;
      if (q_bytes_ > impl_.stats.queued_bytes_max) impl_.stats.queued_bytes_max = q_bytes_;
      note_queue(dropped, 0);
    }
    if (!writing_ && !q_.empty()) write_next();
  }

  Channel channel() const { return ch_; }
  bool replaying = false;
  void close_now() {
    error_code ec;
    beast::get_lowest_layer(ws_).socket().close(ec);
  }

 private:
  void on_accept(error_code ec) {
    if (ec) return;
    if (impl_.clients.size() >= impl_.opt.max_clients) {  // raced past the HTTP check
      impl_.count(&ServerStats::clients_refused);
      ws_.async_close(websocket::close_code::try_again_later, [self = shared_from_this()](error_code) {});
      return;
    }
    id_ = impl_.next_id++;
    impl_.clients[id_] = weak_from_this();
    {
      error_code pec;
      const auto peer = beast::get_lowest_layer(ws_).socket().remote_endpoint(pec);
      std::lock_guard<std::mutex> lock(impl_.stats_mu);
      impl_.stats.clients = impl_.clients.size();
      impl_.stats.clients_total++;
      ClientStats& cs = impl_.clients_stats[id_];
      cs.id = id_;
      cs.channel = ch_;
      cs.peer_port = pec ? 0 : peer.port();
    }
    if (impl_.hooks.hello) {
      std::string hello = impl_.hooks.hello(id_, ch_);
      if (!hello.empty())
        enqueue({std::make_shared<const std::string>(std::move(hello)), ch_ == Channel::Live, false});
    }
    read();
  }

  void read() {
    ws_.async_read(in_, [self = shared_from_this()](error_code ec, size_t) { self->on_read(ec); });
  }

  void on_read(error_code ec) {
    if (ec) return gone();
    if (ch_ == Channel::Live && ws_.got_text() && impl_.hooks.control) {
      impl_.count(&ServerStats::control_messages);
      const std::string text = beast::buffers_to_string(in_.data());
      impl_.hooks.control(id_, text);
    }
    in_.consume(in_.size());
    read();
  }

  void write_next() {
    writing_ = true;
    ws_.binary(q_.front().binary);
    ws_.async_write(net::buffer(*q_.front().msg),
                    [self = shared_from_this()](error_code ec, size_t) { self->on_write(ec); });
  }

  void on_write(error_code ec) {
    writing_ = false;
    if (ec) return gone();
    q_bytes_ -= q_.front().msg->size();
    q_.pop_front();
    {
      std::lock_guard<std::mutex> lock(impl_.stats_mu);
      impl_.stats.messages_sent++;
      note_queue(0, 1);
    }
    if (!q_.empty()) write_next();
  }

  // This client's line of ServerStats::per_client (stats_mu held; none before the accept gave an id).
  void note_queue(uint64_t dropped, uint64_t sent) {
    auto it = impl_.clients_stats.find(id_);
    if (it == impl_.clients_stats.end()) return;
    it->second.dropped += dropped;
    it->second.sent += sent;
    it->second.queued_bytes = q_bytes_;
    it->second.queued_bytes_max = std::max(it->second.queued_bytes_max, q_bytes_);
  }

  void gone() {
    if (closed_) return;
    closed_ = true;
    q_.clear();
    q_bytes_ = 0;
    if (id_ == 0) return;
    impl_.clients.erase(id_);
    {
      std::lock_guard<std::mutex> lock(impl_.stats_mu);
      impl_.stats.clients = impl_.clients.size();
      impl_.clients_stats.erase(id_);
    }
    if (impl_.hooks.closed) impl_.hooks.closed(id_);
  }

  Server::Impl& impl_;
  websocket::stream<beast::tcp_stream> ws_;
  Channel ch_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer in_;
  std::deque<Out> q_;
  size_t q_bytes_ = 0;
  bool writing_ = false, closed_ = false;
  ClientId id_ = 0;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Server::Impl& impl, tcp::socket socket)
      : impl_(impl),
        stream_(std::move(socket)),
        buffer_(impl.opt.max_header_bytes + impl.opt.max_body_bytes),
        slot_(std::make_unique<ConnectionSlot>(&impl.connections)) {}

  void run() { read(); }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(static_cast<uint32_t>(impl_.opt.max_header_bytes));
    parser_->body_limit(impl_.opt.max_body_bytes);
    stream_.expires_after(ms(impl_.opt.idle_timeout_s));
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](error_code ec, size_t) { self->on_read(ec); });
  }

  void on_read(error_code ec) {
    if (ec == http::error::header_limit || ec == http::error::buffer_overflow)
      return error(http::status::request_header_fields_too_large, "request header too large", false);
    if (ec == http::error::body_limit)
      return error(http::status::payload_too_large, "request body too large", false);
    if (ec) {
      if (ec != http::error::end_of_stream && ec != beast::error::timeout && ec != net::error::eof)
        error(http::status::bad_request, "bad request", false);
      else
        close();
      return;
    }
    impl_.count(&ServerStats::http_requests);
    req_ = parser_->release();
    if (websocket::is_upgrade(req_)) return upgrade();
    if (req_.method() != http::verb::get && req_.method() != http::verb::head)
      return error(http::status::method_not_allowed, "only GET and HEAD", req_.keep_alive());
    std::string rel, why;
    const auto t = req_.target();
    if (!resolve_target(std::string_view(t.data(), t.size()), &rel, &why))
      return error(http::status::bad_request, why, false);
    std::filesystem::path file;
    if (!asset_file(impl_.opt.assets, rel, &file, &why))
      return error(http::status::not_found, "not found", req_.keep_alive());
    http::file_body::value_type body;
    body.open(file.c_str(), beast::file_mode::scan, ec);
    if (ec) return error(http::status::not_found, "not found", req_.keep_alive());
    const auto size = body.size();
    if (req_.method() == http::verb::head) {
      auto res = std::make_shared<http::response<http::empty_body>>(http::status::ok, req_.version());
      headers(*res, mime_type(rel));
      res->content_length(size);
      return write(res);
    }
    auto res = std::make_shared<http::response<http::file_body>>(
        std::piecewise_construct, std::make_tuple(std::move(body)),
        std::make_tuple(http::status::ok, req_.version()));
    headers(*res, mime_type(rel));
    res->content_length(size);
    write(res);
  }

  template <class Res>
  void headers(Res& res, std::string_view type) {
    res.set(http::field::server, "voxcap-view");
    res.set(http::field::content_type, beast::string_view(type.data(), type.size()));
    res.set(http::field::cache_control, "no-cache");
    res.set("X-Content-Type-Options", "nosniff");
    res.keep_alive(req_.keep_alive());
  }

  void upgrade() {
    const auto t = req_.target();
    const std::string_view target(t.data(), t.size());
    Channel ch;
    if (target == "/ws")
      ch = Channel::Live;
    else if (target == "/pose.json")
      ch = Channel::PoseJson;
    else
      return error(http::status::not_found, "no WebSocket here (/ws, /pose.json)", false);
    if (impl_.clients.size() >= impl_.opt.max_clients) {
      impl_.count(&ServerStats::clients_refused);
      return error(http::status::service_unavailable, "too many viewer clients", false);
    }
    stream_.expires_never();
    if (impl_.opt.send_buffer_bytes > 0) {
      error_code bec;  // best effort: the kernel may clamp it (net.core.wmem_max)
      stream_.socket().set_option(
          net::socket_base::send_buffer_size(static_cast<int>(impl_.opt.send_buffer_bytes)), bec);
    }
    std::make_shared<WsSession>(impl_, stream_.release_socket(), ch, std::move(slot_))->run(req_);
  }

  void error(http::status status, std::string_view text, bool keep_alive) {
    impl_.count(&ServerStats::http_errors);
    auto res =
        std::make_shared<http::response<http::string_body>>(status, req_.version() ? req_.version() : 11);
    res->set(http::field::server, "voxcap-view");
    res->set(http::field::content_type, "text/plain; charset=utf-8");
    res->body() = std::string(text) + "\n";  // NOLINT
    res->keep_alive(keep_alive);
    res->prepare_payload();
    write(res);
  }

  template <class Res>
  void write(std::shared_ptr<Res> res) {
    stream_.expires_after(ms(impl_.opt.idle_timeout_s));
    http::async_write(stream_, *res, [self = shared_from_this(), res](error_code ec, size_t) {
      if (ec || !res->keep_alive()) return self->close();
      self->read();
    });
  }

  void close() {
    error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  Server::Impl& impl_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  http::request<http::string_body> req_;
  std::unique_ptr<ConnectionSlot> slot_;
};

void Server::Impl::accept() {
  acceptor->async_accept([this](error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted) return;
    if (!ec) {
      if (connections.load() >= opt.max_connections) {
        count(&ServerStats::connections_refused);
        socket.close(ec);
      } else {
        std::make_shared<HttpSession>(*this, std::move(socket))->run();
      }
    }
    if (acceptor->is_open()) accept();
  });
}

void Server::Impl::tick() {
  ticker->expires_after(ms(opt.tick_s));
  ticker->async_wait([this](error_code ec) {
    if (ec) return;
    if (hooks.tick) hooks.tick();
    tick();
  });
}

Server::Server(ServerOptions options, Hooks hooks) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.valid(&why)) throw std::invalid_argument(why);
  impl_->opt = std::move(options);
  impl_->hooks = std::move(hooks);
}

Server::~Server() {
  stop();
}

void Server::start() {
  Impl& m = *impl_;
  if (m.running) return;
  error_code ec;
  const auto addr = m.opt.bind == "any" ? net::ip::address_v4::any() : net::ip::make_address_v4(m.opt.bind);
  const tcp::endpoint ep(addr, m.opt.port);
  m.acceptor.emplace(*m.ioc);
  m.acceptor->open(ep.protocol(), ec);
  if (!ec) m.acceptor->set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) m.acceptor->bind(ep, ec);
  if (!ec) m.acceptor->listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error(
        fmt::format("viewer: cannot listen on {}:{}: {}", m.opt.bind, m.opt.port, ec.message()));
  m.port = m.acceptor->local_endpoint().port();
  m.ticker.emplace(*m.ioc);
  m.accept();
  m.tick();
  m.running = true;
  m.thread = std::thread([&m] {
    for (;;) {
      try {
        m.ioc->run();
        return;
      } catch (const std::exception&) {
        // A handler threw (it should not): the server goes on.
      }
    }
  });
}

void Server::stop() {
  Impl& m = *impl_;
  if (!m.running.exchange(false)) return;
  net::post(*m.ioc, [&m] {
    error_code ec;
    if (m.acceptor) m.acceptor->close(ec);
    if (m.ticker) m.ticker->cancel();
    for (auto& [id, w] : m.clients)
      if (auto s = w.lock()) s->close_now();
  });
  // Give the closes a moment to run, then stop the loop; what is left is destroyed with the context.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  m.ioc->stop();
  if (m.thread.joinable()) m.thread.join();
  m.clients.clear();
  std::lock_guard<std::mutex> lock(m.stats_mu);
  m.clients_stats.clear();
}

uint16_t Server::port() const {
  return impl_->port;
}

void Server::broadcast(Channel channel, std::shared_ptr<const std::string> msg, bool binary) {
  if (!impl_->running || !msg || msg->empty()) return;
  net::post(*impl_->ioc, [m = impl_.get(), channel, msg = std::move(msg), binary] {
    for (auto& [id, w] : m->clients)
      if (auto s = w.lock())
        if (s->channel() == channel && !s->replaying) s->enqueue({msg, binary, true});
  });
}

void Server::broadcast_always(std::shared_ptr<const std::string> msg) {
  if (!impl_->running || !msg || msg->empty()) return;
  net::post(*impl_->ioc, [m = impl_.get(), msg = std::move(msg)] {
    for (auto& [id, w] : m->clients)
      if (auto s = w.lock())
        if (s->channel() == Channel::Live) s->enqueue({msg, true, true});
  });
}

void Server::send(ClientId client, std::shared_ptr<const std::string> msg, bool binary, bool droppable) {
  if (!impl_->running || !msg || msg->empty()) return;
  net::post(*impl_->ioc, [m = impl_.get(), client, msg = std::move(msg), binary, droppable] {
    auto it = m->clients.find(client);
    if (it == m->clients.end()) return;
    if (auto s = it->second.lock()) s->enqueue({msg, binary, droppable});
  });
}

void Server::set_replaying(ClientId client, bool replaying) {
  if (!impl_->running) return;
  net::post(*impl_->ioc, [m = impl_.get(), client, replaying] {
    auto it = m->clients.find(client);
    if (it == m->clients.end()) return;
    if (auto s = it->second.lock()) s->replaying = replaying;
  });
}

ServerStats Server::stats() const {
  std::lock_guard<std::mutex> lock(impl_->stats_mu);
  ServerStats s = impl_->stats;
  s.per_client.reserve(impl_->clients_stats.size());
  for (const auto& [id, c] : impl_->clients_stats) s.per_client.push_back(c);
  return s;
}

}  // namespace vc::view
