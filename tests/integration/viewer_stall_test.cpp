// Issue #15, "checked by": with three browsers connected, one of them paused, the rig still completes
// every frame and the host's memory stays bounded. The emulated rig (real voxcap-edge processes on
// loopback, the host in this process) runs with its viewer (host/view); three WebSocket clients on
// 127.0.0.1 connect to /ws: two read everything on threads of their own, one completes the handshake
// and never reads again, with a 4 KiB receive buffer set before it connects; with the server's bounded
// send buffer (ServerOptions::send_buffer_bytes) the kernel's loopback buffers cannot absorb the stream
// for long. The viewer's per-client queue (64 messages, 8 MiB,
// drop-oldest) must then drop the paused client's oldest messages — its own drop counter grows, the
// readers' do not take its drops — while the readers keep receiving, every merged frame is complete
// (a 1 s deadline: CPU load cannot make a node late), and the host's resident memory stays within
// kRssBoundKb of what it was once all three were connected (host/view/README.md states the bound).
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility> (host/view/src/server.cpp).
#include <utility>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "voxcap/emulated/emulated_rig.hpp"
#include "voxcap/view/encode.hpp"
#include "voxcap/view/viewer.hpp"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/allocator_interface.h>
#define VC_TEST_ASAN 1
#endif
#endif

namespace vc::view {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

// Three full per-client queues (3 x 8 MiB, ServerOptions::max_queue_bytes) and 8 MiB for the rest.
constexpr long kRssBoundKb = 32 * 1024;

// Resident memory of this process (the host) in kB, AddressSanitizer's quarantine handed back first
// (as tests/integration/attack_test.cpp does).
long live_rss_kb() {
#ifdef VC_TEST_ASAN
  __sanitizer_purge_allocator();
#endif
  return emulated::rss_kb();
}

// A /ws client on its own socket. rcvbuf > 0: SO_RCVBUF set before connecting (so the window the kernel
// offers is small from the start).
struct Client {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  uint16_t port = 0;  // its local port: how the server's per-client stats name it

  void connect(uint16_t server_port, int rcvbuf) {
    tcp::socket& s = ws.next_layer();
    s.open(tcp::v4());
    if (rcvbuf > 0) s.set_option(net::socket_base::receive_buffer_size(rcvbuf));
    // A reader blocked for 10 s gives up: the loop ends even if the server never closes.
    const timeval tv{10, 0};
    ::setsockopt(s.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    s.connect({net::ip::make_address("127.0.0.1"), server_port});
    ws.handshake("127.0.0.1", "/ws");
    port = s.local_endpoint().port();
  }
};

// Reads every message until the connection ends; counts them, and the hulls among them.
struct Reader {
  Client c;
  std::atomic<uint64_t> messages{0}, hulls{0}, bytes{0};
  std::thread thread;

  void start() {
    thread = std::thread([this] {
      beast::flat_buffer b;
      for (int i = 0; i < 1'000'000; i++) {  // bounded: ~30 messages a second for a minute or two
        beast::error_code ec;
        c.ws.read(b, ec);
        if (ec) return;
        const auto* p = static_cast<const uint8_t*>(b.data().data());
        if (b.size() >= 4 && p[0] == static_cast<uint8_t>(MsgType::Hull)) hulls++;
        bytes += b.size();
        messages++;
        b.consume(b.size());
      }
    });
  }
  void join() {
    if (thread.joinable()) thread.join();
  }
  // A test that ends early (a failed ASSERT) still ends the thread: the socket is shut down under it.
  ~Reader() {
    if (thread.joinable()) ::shutdown(c.ws.next_layer().native_handle(), SHUT_RDWR);
    join();
  }
};

const ClientStats* find_client(const ServerStats& s, uint16_t port) {
  for (const ClientStats& c : s.per_client)
    if (c.peer_port == port) return &c;
  return nullptr;
}

TEST(ViewerStall, ThreeBrowsersOnePausedTheRigCompletesEveryFrameAndMemoryStaysBounded) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("vc_viewer_stall_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "web");
  std::ofstream(dir / "web" / "index.html") << "<!doctype html><title>voxcap</title>";

  ViewerOptions vo;
  vo.server.bind = "127.0.0.1";
  vo.server.port = 0;
  vo.server.assets = dir / "web";
  vo.record_switch = false;  // this test is about the live stream
  vo.record_dir = dir / "recordings";
  Viewer viewer(vo);

  emulated::Options o;
  o.nodes = 3;
  o.motion = "wave";
  o.width = 160;
  o.height = 120;
  o.grid = 64;
  o.rate_hz = 30;
  o.deadline_ms = 1000;  // long enough that CPU load cannot make a node late: every frame complete
  o.missing_policy = "degraded";
  o.truth_every = 0;
  o.keyed = false;
  o.edge_binary = VOXCAP_EDGE_BINARY;
  o.stages = [&](pipeline::Pipeline& p) { viewer.attach(p); };
  emulated::EmulatedRig rig(o);
  viewer.set_report([&rig] { return rig.report(); });
  viewer.start();
  rig.start(60);

  Reader readers[2];
  Client paused;
  for (Reader& r : readers) {
    r.c.connect(viewer.port(), 0);
    r.start();
  }
  paused.connect(viewer.port(), 4096);  // then never read again
  rig.run_frames(30, 60);               // everyone connected, the stream going
  const long rss_before = live_rss_kb();
  const aggregator::Report before = rig.report();

  // Until the paused client's queue has dropped messages for a while (bounded: 90 s of frames).
  long rss_peak = rss_before;
  uint64_t readers_at_first_drop[2] = {0, 0};
  bool dropping = false;
  double first_drop_s = -1;
  const auto t0 = Clock::now();
  const auto end = t0 + std::chrono::seconds(90);
  uint64_t frames_after_drop = 0, frames_at_drop = 0, dropped_at_first = 0;
  while (Clock::now() < end) {
    rig.run_seconds(0.5);
    rss_peak = std::max(rss_peak, live_rss_kb());
    const ServerStats st = viewer.server_stats();
    const ClientStats* p = find_client(st, paused.port);
    ASSERT_NE(p, nullptr) << "the paused client was disconnected";
    if (!dropping && p->dropped > 0) {
      dropping = true;
      first_drop_s = std::chrono::duration<double>(Clock::now() - t0).count();
      for (int k = 0; k < 2; k++) readers_at_first_drop[k] = readers[k].hulls;
      frames_at_drop = rig.report().frames;
      dropped_at_first = p->dropped;
    }
    if (dropping) {
      frames_after_drop = rig.report().frames - frames_at_drop;
      if (frames_after_drop >= 150) break;  // 5 s of frames at 30 Hz with the paused client dropping
    }
  }
  const ServerStats st = viewer.server_stats();
  const aggregator::Report after = rig.report();
  const long rss_after = live_rss_kb();
  const emulated::Result r = rig.stop();
  viewer.stop();  // closes the clients: the readers' loops end
  for (Reader& rd : readers) rd.join();
  fs::remove_all(dir);

  RecordProperty("seconds_to_first_drop", std::to_string(first_drop_s));
  RecordProperty("rss_growth_peak_kb", std::to_string(rss_peak - rss_before));
  RecordProperty("frames", std::to_string(r.report.frames));
  ASSERT_TRUE(dropping) << "the paused client's queue never dropped in 90 s: kernel buffers absorbed it";
  const ClientStats* p = find_client(st, paused.port);
  ASSERT_NE(p, nullptr);
  RecordProperty("paused_dropped", std::to_string(p->dropped));
  RecordProperty("paused_queued_bytes_max", std::to_string(p->queued_bytes_max));
  for (int k = 0; k < 2; k++)
    std::printf("reader %d: %llu messages, %llu hulls, %llu bytes\n", k,
                static_cast<unsigned long long>(readers[k].messages.load()),
                static_cast<unsigned long long>(readers[k].hulls.load()),
                static_cast<unsigned long long>(readers[k].bytes.load()));
  std::printf(
      "paused client: %llu dropped, %llu sent, queue max %zu B; first drop after %.1f s; host RSS +%ld kB "
      "peak\n",
      static_cast<unsigned long long>(p->dropped), static_cast<unsigned long long>(p->sent),
      p->queued_bytes_max, first_drop_s, rss_peak - rss_before);

  // The paused client: its own counter grew, its queue stayed within its bound.
  EXPECT_GT(p->dropped, dropped_at_first) << "its drops went on growing while it stayed paused";
  EXPECT_LE(p->queued_bytes_max, vo.limits.max_queue_bytes + kMaxHullRle);
  // The readers kept receiving after the paused client's drops began, with every hull the stage sent
  // in that time (the stage sends at most max_hz, 30 Hz: every frame of this rig) less a margin for
  // the ones in flight; their queues did not take the paused client's drops.
  for (int k = 0; k < 2; k++) {
    const uint64_t since = readers[k].hulls - readers_at_first_drop[k];
    RecordProperty("reader" + std::to_string(k) + "_hulls", std::to_string(readers[k].hulls.load()));
    EXPECT_GE(since, frames_after_drop / 2) << "reader " << k << " stopped receiving";
    const ClientStats* c = find_client(st, readers[k].c.port);
    ASSERT_NE(c, nullptr);
    EXPECT_LT(c->dropped, p->dropped) << "reader " << k;
  }
  // The rig: every frame merged, none dropped or evicted, no hull late for its frame and none dropped by
  // the host, before and during the stall; every frame complete unless an edge itself reported frames
  // it did not make (its pairing or queue: an edge process starved of CPU on a loaded machine, which no
  // deadline helps), and then no more degraded frames than those.
  uint64_t edge_drops = 0;
  for (const aggregator::NodeReport& n : r.report.nodes) {
    edge_drops += n.edge_queue_drops + n.edge_pulses_without_frame;
    EXPECT_EQ(n.late, 0u) << "node " << n.id;
    EXPECT_EQ(n.host_queue_drops, 0u) << "node " << n.id;
    std::printf(
        "node %u: %llu hulls, %llu missing, %llu late, edge drops %llu queue + %llu pulses without frame\n",
        static_cast<unsigned>(n.id), static_cast<unsigned long long>(n.hulls),
        static_cast<unsigned long long>(n.missing), static_cast<unsigned long long>(n.late),
        static_cast<unsigned long long>(n.edge_queue_drops),
        static_cast<unsigned long long>(n.edge_pulses_without_frame));
  }
  RecordProperty("degraded", std::to_string(r.report.degraded));
  RecordProperty("edge_drops", std::to_string(edge_drops));
  if (edge_drops == 0)
    EXPECT_EQ(r.report.degraded, 0u) << "of " << r.report.frames << " frames";
  else
    EXPECT_LE(r.report.degraded, edge_drops) << "frames degraded beyond what the edges themselves dropped";
  EXPECT_EQ(r.report.dropped, 0u);
  EXPECT_EQ(r.report.evicted, 0u);
  EXPECT_GE(after.frames, before.frames + frames_after_drop);
  EXPECT_FALSE(r.report.merging_stopped());
  // Host memory: bounded while a client is paused.
  EXPECT_LT(rss_peak - rss_before, kRssBoundKb) << "host memory grew by " << (rss_peak - rss_before) << " kB";
  EXPECT_LT(rss_after - rss_before, kRssBoundKb);
}

}  // namespace
}  // namespace vc::view
