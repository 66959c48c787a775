// The viewer's server on loopback: files served with their types, hostile requests refused, limits
// held, and a client that never reads costs a bounded queue while the others get every message.
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility>: gcc 12's C++20
// headers no longer bring it in through <memory> (clang's libstdc++ build happens to).
#include <utility>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "voxcap/view/server.hpp"

namespace vc::view {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;

struct Fixture : ::testing::Test {
  std::filesystem::path root;
  void SetUp() override {
    root = std::filesystem::temp_directory_path() / ("vc_view_server_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root);
    std::filesystem::create_directories(root / "www" / "lib");
    std::ofstream(root / "www" / "index.html") << "<!doctype html><title>voxcap</title>";
    std::ofstream(root / "www" / "lib" / "a.js") << "export const a = 1;";
    std::ofstream(root / "secret.txt") << "secret";
  }
  void TearDown() override { std::filesystem::remove_all(root); }
  ServerOptions options() {
    ServerOptions o;
    o.port = 0;
    o.assets = root / "www";
    return o;
  }
};

// One raw request; the whole answer (the server closes after it: Connection: close).
std::string raw(uint16_t port, const std::string& request) {
  net::io_context ioc;
  tcp::socket s(ioc);
  s.connect({net::ip::make_address("127.0.0.1"), port});
  net::write(s, net::buffer(request));
  std::string out;
  beast::error_code ec;
  char buf[4096];
  for (int i = 0; i < 1000; i++) {
    size_t n = s.read_some(net::buffer(buf), ec);
    out.append(buf, n);
    if (ec) break;
  }
  return out;
}

std::string get(uint16_t port, const std::string& target) {
  return raw(port, "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
}

TEST_F(Fixture, ServesFilesWithTheirTypes) {
  Server server(options(), {});
  server.start();
  const std::string index = get(server.port(), "/");
  EXPECT_NE(index.find("HTTP/1.1 200"), std::string::npos);
  EXPECT_NE(index.find("Content-Type: text/html; charset=utf-8"), std::string::npos);
  EXPECT_NE(index.find("<title>voxcap</title>"), std::string::npos);
  const std::string js = get(server.port(), "/lib/a.js");
  EXPECT_NE(js.find("text/javascript"), std::string::npos);
  EXPECT_NE(get(server.port(), "/nothing.js").find("HTTP/1.1 404"), std::string::npos);
}

TEST_F(Fixture, RefusesTraversalMethodsAndLargeRequests) {
  Server server(options(), {});
  server.start();
  for (const char* t :
       {"/../secret.txt", "/%2e%2e/secret.txt", "/lib/../../secret.txt", "/.%2e/secret.txt"}) {
    const std::string r = get(server.port(), t);
    EXPECT_EQ(r.find("secret\n"), std::string::npos) << t;
    EXPECT_NE(r.find("HTTP/1.1 400"), std::string::npos) << t << ": " << r.substr(0, 40);
  }
  EXPECT_NE(
      raw(server.port(), "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\nConnection: close\r\n\r\nab")
          .find("HTTP/1.1 405"),
      std::string::npos);
  EXPECT_NE(raw(server.port(),
                "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n" + std::string(2000, 'x'))
                .find("HTTP/1.1 413"),
            std::string::npos);
  EXPECT_NE(raw(server.port(), "GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'a') + "\r\n\r\n")
                .find("HTTP/1.1 431"),
            std::string::npos);
  EXPECT_NE(raw(server.port(), "garbage\r\n\r\n").find("HTTP/1.1 400"), std::string::npos);
  EXPECT_GE(server.stats().http_errors, 7u);
  // Still serving.
  EXPECT_NE(get(server.port(), "/").find("HTTP/1.1 200"), std::string::npos);
}

TEST_F(Fixture, StalledClientIsBoundedOthersGetEverything) {
  ServerOptions o = options();
  o.max_queue_messages = 16;
  o.max_queue_bytes = 1u << 20;
  std::atomic<int> controls{0};
  Server::Hooks hooks;
  hooks.hello = [](ClientId, Channel) { return std::string("hello"); };
  hooks.control = [&](ClientId, std::string_view t) {
    if (t == "ping") controls++;
  };
  Server server(o, hooks);
  server.start();
  net::io_context ioc;
  auto connect = [&](const char* path) {
    auto ws = std::make_unique<websocket::stream<tcp::socket>>(ioc);
    beast::get_lowest_layer(*ws).connect({net::ip::make_address("127.0.0.1"), server.port()});
    ws->handshake("127.0.0.1", path);
    return ws;
  };
  auto reader = connect("/ws");
  auto stalled = connect("/ws");
  // The stalled client's receive buffer is made small so its queue on the server fills quickly.
  beast::get_lowest_layer(*stalled).set_option(net::socket_base::receive_buffer_size(4096));
  beast::flat_buffer b;
  reader->read(b);
  EXPECT_EQ(beast::buffers_to_string(b.data()), "hello");
  b.consume(b.size());
  reader->text(true);
  reader->write(net::buffer(std::string("ping")));
  // 400 messages of 64 KiB: 25 MiB in all, far over the stalled client's 1 MiB queue.
  const int kMessages = 400;
  for (int i = 0; i < kMessages; i++) {
    auto m = std::make_shared<std::string>(64 * 1024, char('a' + i % 26));
    (*m)[0] = char(i & 0xFF);
    (*m)[1] = char(i >> 8);
    server.broadcast(Channel::Live, m, true);
    // The reader keeps up: read what it is sent.
    reader->read(b);
    ASSERT_EQ(b.size(), 64u * 1024);
    const auto* p = static_cast<const unsigned char*>(b.data().data());
    ASSERT_EQ(p[0] | (p[1] << 8), i);
    b.consume(b.size());
  }
  const ServerStats st = server.stats();
  EXPECT_GT(st.messages_dropped, 0u);
  EXPECT_LE(st.queued_bytes_max, o.max_queue_bytes + 64 * 1024);
  EXPECT_EQ(st.clients, 2u);
  EXPECT_EQ(controls.load(), 1);
  // Per client, told apart by their ports: the drops are all the stalled one's.
  ASSERT_EQ(st.per_client.size(), 2u);
  const uint16_t reader_port = beast::get_lowest_layer(*reader).local_endpoint().port();
  const uint16_t stalled_port = beast::get_lowest_layer(*stalled).local_endpoint().port();
  for (const ClientStats& c : st.per_client) {
    EXPECT_EQ(c.channel, Channel::Live);
    if (c.peer_port == reader_port) {
      EXPECT_EQ(c.dropped, 0u);
      EXPECT_GE(c.sent, static_cast<uint64_t>(kMessages));  // the hello and all (the last may be in flight)
    } else {
      EXPECT_EQ(c.peer_port, stalled_port);
      EXPECT_EQ(c.dropped, st.messages_dropped);
      EXPECT_LE(c.queued_bytes_max, o.max_queue_bytes + 64 * 1024);
    }
  }
  server.stop();
  EXPECT_TRUE(server.stats().per_client.empty());
}

TEST_F(Fixture, TooManyClientsAreRefused) {
  ServerOptions o = options();
  o.max_clients = 2;
  Server server(o, {});
  server.start();
  net::io_context ioc;
  std::vector<std::unique_ptr<websocket::stream<tcp::socket>>> ws;
  int refused = 0;
  for (int i = 0; i < 3; i++) {
    auto w = std::make_unique<websocket::stream<tcp::socket>>(ioc);
    beast::get_lowest_layer(*w).connect({net::ip::make_address("127.0.0.1"), server.port()});
    beast::error_code ec;
    w->handshake("127.0.0.1", "/ws", ec);
    if (ec) refused++;
    ws.push_back(std::move(w));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the accept runs on the server's thread
  }
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(server.stats().clients_refused, 1u);
}

}  // namespace
}  // namespace vc::view
