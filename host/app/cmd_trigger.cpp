// `voxcap trigger test`: emits a pulse train through any backend and prints what was sent.
// `voxcap trigger listen`: receives the emulated (udp) trigger like an edge would and prints it.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "voxcap/base/clock.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/proto.hpp"
#include "voxcap/trigger/generator.hpp"

namespace vc::cli {
namespace {

std::atomic<bool> g_interrupted{false};

void on_sigint(int) {
  g_interrupted = true;
}

// Ctrl-C ends the command cleanly (the train is stopped, the summary printed) while it is alive.
class InterruptScope {
 public:
  InterruptScope() {
    g_interrupted = false;
    struct sigaction sa {};
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptScope() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

struct TestArgs {
  std::string rig;
  std::string backend;
  double rate_hz = 0;
  double width_us = 0;
  uint64_t count = 10;
  double duration_s = 0;
  std::vector<std::string> targets;
  std::string chip;
  std::string line;
  bool active_low = false;
  std::string usb_id;
  std::string serial;
  int pin = -1;
  uint32_t sample_rate_hz = 0;
  int rt_priority = -1;
  bool quiet = false;
  bool json = false;
};

uint16_t parse_hex16(const std::string& text, const char* what) {
  size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used, 16);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || v > 0xffff)
    throw UsageError(fmt::format("--usb: bad {} \"{}\" (hex, e.g. 0403:6014)", what, text));
  return static_cast<uint16_t>(v);
}

config::TriggerOptions options_from(const TestArgs& a) {
  config::TriggerOptions t;
  if (!a.rig.empty()) {
    try {
      t = config::load_rig_config(a.rig).trigger;
    } catch (const config::ConfigError& e) {
      throw UsageError(e.what());
    }
  }
  if (!a.backend.empty() && !config::parse_trigger_backend(a.backend, &t.backend))
    throw UsageError(fmt::format("--backend: must be udp, gpiod or ftdi, got \"{}\"", a.backend));
  if (a.rate_hz > 0) t.rate_hz = a.rate_hz;
  if (a.width_us > 0) t.pulse_width_us = a.width_us;
  if (a.active_low) t.active_low = true;
  if (a.rt_priority >= 0) t.rt_priority = a.rt_priority;
  if (!a.targets.empty()) {
    t.udp.targets.clear();
    for (const std::string& s : a.targets) {
      config::Endpoint e;
      std::string why;
      if (!config::Endpoint::parse(s, &e, &why)) throw UsageError("--target: " + why);
      t.udp.targets.push_back(e);
    }
  }
  if (!a.chip.empty()) t.gpiod.chip = a.chip;
  if (!a.line.empty()) {
    const bool numeric = a.line.find_first_not_of("0123456789") == std::string::npos;
    t.gpiod.line_offset = numeric ? std::stoi(a.line) : -1;
    t.gpiod.line_name = numeric ? "" : a.line;
  }
  if (!a.usb_id.empty()) {
    const size_t colon = a.usb_id.find(':');
    if (colon == std::string::npos) throw UsageError("--usb: expected VID:PID, e.g. 0403:6014");
    t.ftdi.vid = parse_hex16(a.usb_id.substr(0, colon), "vendor id");
    t.ftdi.pid = parse_hex16(a.usb_id.substr(colon + 1), "product id");
  }
  if (!a.serial.empty()) t.ftdi.serial = a.serial;
  if (a.pin >= 0) t.ftdi.pin = a.pin;
  if (a.sample_rate_hz > 0) t.ftdi.sample_rate_hz = a.sample_rate_hz;

  if (t.backend == config::TriggerBackend::Udp && t.udp.targets.empty())
    throw UsageError(
        "the udp backend needs at least one --target host:port (or --rig with trigger.udp.targets)");
  std::string why;
  if (!t.valid(&why)) throw UsageError("trigger." + why);
  return t;
}

void run_test(const TestArgs& a) {
  const config::TriggerOptions options = options_from(a);
  if (a.count == 0 && a.duration_s <= 0 && a.json)
    throw UsageError("--json needs a finite run: give --count or --duration");
  std::unique_ptr<trigger::Generator> gen = trigger::make_generator(options);
  const bool print_pulses = !a.quiet && !a.json;
  // Timing figures of this run: lateness against the schedule (host-timed backends) and how far each
  // interval between consecutive pulse times is from a whole number of periods.
  std::mutex timing_mutex;
  std::vector<double> lateness_us;
  double interval_error_max_us = 0;
  int64_t last_t_ns = 0;
  const double period_ns = 1e9 / options.rate_hz;
  gen->set_observer([&](const trigger::Pulse& p) {
    {
      std::lock_guard<std::mutex> lock(timing_mutex);
      lateness_us.push_back(static_cast<double>(p.lateness_ns) / 1e3);
      if (last_t_ns != 0) {
        const double interval = static_cast<double>(p.t_ns - last_t_ns);
        interval_error_max_us =
            std::max(interval_error_max_us,
                     std::fabs(interval - period_ns * std::max(1.0, std::round(interval / period_ns))) / 1e3);
      }
      last_t_ns = p.t_ns;
    }
    if (print_pulses) {
      // Line-buffered so a pipe (| head, a log) sees each pulse as it goes out.
      fmt::print("pulse seq={} t_ns={} late_us={:.1f}\n", p.seq, p.t_ns,
                 static_cast<double>(p.lateness_ns) / 1e3);
      (void)std::fflush(stdout);
    }
  });
  if (!a.json)
    spdlog::info("trigger test on {}: {} Hz, {} us, {}", gen->describe(), options.rate_hz,
                 options.pulse_width_us,
                 a.count ? fmt::format("{} pulses", a.count) : std::string("until Ctrl-C"));

  InterruptScope interrupt;
  const auto t0 = std::chrono::steady_clock::now();
  gen->start(trigger::PulseTrain{options.rate_hz, options.pulse_width_us, a.count, 0});
  while (!gen->wait_done(std::chrono::milliseconds(50))) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (g_interrupted || (a.duration_s > 0 && elapsed >= a.duration_s)) break;
  }
  gen->stop();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const trigger::Stats s = gen->stats();
  const std::string error = gen->last_error();
  std::sort(lateness_us.begin(), lateness_us.end());
  auto percentile = [&](double q) {
    return lateness_us.empty()
               ? 0.0
               : lateness_us[static_cast<size_t>(q * static_cast<double>(lateness_us.size() - 1))];
  };
  if (a.json) {
    nlohmann::json j = {{"backend", std::string(gen->backend())},
                        {"target", gen->describe()},
                        {"rate_hz", options.rate_hz},
                        {"pulse_width_us", options.pulse_width_us},
                        {"pulses_sent", s.pulses_sent},
                        {"late", s.late},
                        {"missed", s.missed},
                        {"underruns", s.underruns},
                        {"paused_ms", static_cast<double>(s.paused_ns) / 1e6},
                        {"errors", s.errors},
                        {"max_lateness_us", static_cast<double>(s.max_lateness_ns) / 1e3},
                        {"lateness_p50_us", percentile(0.5)},
                        {"lateness_p99_us", percentile(0.99)},
                        {"interval_error_max_us", interval_error_max_us},
                        {"pin_edges", s.pin_edges},
                        {"sample_rate_hz", s.sample_rate_hz},
                        {"elapsed_s", elapsed},
                        {"error", error}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print(
        "sent {} pulses in {:.3f} s via {} (late {}, missed {}, lateness p50 {:.1f} / p99 {:.1f} / max "
        "{:.1f} us, "
        "interval error max {:.1f} us",
        s.pulses_sent, elapsed, gen->backend(), s.late, s.missed, percentile(0.5), percentile(0.99),
        static_cast<double>(s.max_lateness_ns) / 1e3, interval_error_max_us);
    if (options.backend == config::TriggerBackend::Udp) fmt::print(", send errors {}", s.errors);
    if (options.backend == config::TriggerBackend::Ftdi)
      fmt::print(", underruns {} ({:.1f} ms), pin edges {}, bit-bang {:.1f} Hz", s.underruns,
                 static_cast<double>(s.paused_ns) / 1e6, s.pin_edges, s.sample_rate_hz);
    fmt::print(")\n");
  }
  if (!error.empty()) throw std::runtime_error(error);
}

struct ListenArgs {
  std::string bind = "127.0.0.1";
  uint16_t port = 0;
  uint64_t count = 0;
  double timeout_s = 5.0;
  bool quiet = false;
};

void run_listen(const ListenArgs& a) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(a.port);
  if (inet_pton(AF_INET, a.bind.c_str(), &sa.sin_addr) != 1)
    throw UsageError(fmt::format("--bind: not an IPv4 address: \"{}\"", a.bind));
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(fmt::format("socket: {}", std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  if (bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) < 0)
    throw std::runtime_error(fmt::format("cannot bind {}:{}: {}", a.bind, a.port, std::strerror(errno)));
  socklen_t len = sizeof sa;
  getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len);
  spdlog::info("listening for trigger datagrams on {}:{}", a.bind, ntohs(sa.sin_port));

  InterruptScope interrupt;
  uint64_t received = 0, missing = 0, invalid = 0;
  bool have_last = false;
  uint64_t last_seq = 0;
  while (!g_interrupted && (a.count == 0 || received < a.count)) {
    pollfd p{fd, POLLIN, 0};
    const int rc = poll(&p, 1, static_cast<int>(a.timeout_s * 1000));
    if (rc < 0 && errno == EINTR) continue;
    if (rc <= 0) break;  // quiet for --timeout: the sender is done
    uint8_t buf[256];
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    const int64_t now = static_cast<int64_t>(vc::monotonic_ns());
    const auto pulse = n < 0 ? std::nullopt : proto::decode_trigger({buf, static_cast<size_t>(n)});
    if (!pulse) {
      ++invalid;
      continue;
    }
    const uint64_t seq = pulse->seq, t_ns = pulse->t_ns;
    if (have_last && seq > last_seq + 1) {
      missing += seq - last_seq - 1;
      if (!a.quiet) fmt::print("gap: {} pulses missing before seq {}\n", seq - last_seq - 1, seq);
    }
    have_last = true;
    last_seq = seq;
    ++received;
    if (!a.quiet)
      fmt::print("pulse seq={} t_ns={} delivery_us={:.1f}\n", seq, t_ns,
                 static_cast<double>(now - static_cast<int64_t>(t_ns)) / 1e3);
    (void)std::fflush(stdout);
  }
  fmt::print("received {} pulses ({} missing, {} invalid datagrams)\n", received, missing, invalid);
}

}  // namespace

void add_trigger_commands(CLI::App& app) {
  CLI::App* group =
      app.add_subcommand("trigger", "Trigger generation: emit test pulse trains, watch the emulated trigger");
  group->require_subcommand(1, 1);

  auto t = std::make_shared<TestArgs>();
  CLI::App* test = group->add_subcommand(
      "test",
      "Emit a pulse train through a trigger backend and print each pulse sent (seq, CLOCK_MONOTONIC time, "
      "lateness) and a summary; settings come from --rig's [trigger] and the options below");
  test->add_option("--rig", t->rig,
                   "Take the [trigger] settings from this rig.toml (options below override)");
  test->add_option("--backend", t->backend,
                   "udp (emulated, loopback datagrams), gpiod (GPIO line) or ftdi (USB box)")
      ->check(CLI::IsMember({"udp", "gpiod", "ftdi"}));
  test->add_option("--rate", t->rate_hz, "Pulses per second, (0, 1000] (default 60)");
  test->add_option("--width", t->width_us,
                   "Pulse width in microseconds, below half the period (default 100)");
  test->add_option("--count", t->count, "Pulses to emit; 0 = until Ctrl-C or --duration (default 10)");
  test->add_option("--duration", t->duration_s, "Stop after this many seconds");
  test->add_option("--target", t->targets, "udp: a loopback host:port to send each pulse to (repeatable)");
  test->add_option("--chip", t->chip, "gpiod: the GPIO chip (/dev/gpiochip0 or gpiochip0)");
  test->add_option("--line", t->line, "gpiod: the output line, by offset (18) or name (GPIO18)");
  test->add_flag("--active-low", t->active_low, "The line idles high and pulses low (gpiod, ftdi)");
  test->add_option("--usb", t->usb_id, "ftdi: USB VID:PID in hex (default 0403:6014, an FT232H)");
  test->add_option("--serial", t->serial, "ftdi: the box's USB serial number, when several are plugged in");
  test->add_option("--pin", t->pin, "ftdi: the ADBUS bit driving the trigger (default 3)")
      ->check(CLI::Range(0, 7));
  test->add_option("--sample-rate", t->sample_rate_hz,
                   "ftdi: bit-bang clock in Hz, 10000..1000000 (default 100000)");
  test->add_option("--rt-priority", t->rt_priority,
                   "SCHED_FIFO priority of the pulse thread, 0 = normal (default 50)")
      ->check(CLI::Range(0, 99));
  test->add_flag("--quiet", t->quiet, "Print only the summary");
  test->add_flag(
      "--json", t->json,
      "Print only a JSON summary: backend, target, rate_hz, pulse_width_us, pulses_sent, late, missed, "
      "underruns, paused_ms, errors, max_lateness_us, lateness_p50_us, lateness_p99_us, "
      "interval_error_max_us "
      "(largest distance of a pulse interval from a whole number of periods), pin_edges, sample_rate_hz "
      "(ftdi: measured bit-bang clock), elapsed_s, error (empty when none)");
  test->callback([t] { run_test(*t); });

  auto l = std::make_shared<ListenArgs>();
  CLI::App* listen = group->add_subcommand(
      "listen",
      "Receive trigger datagrams (the udp backend's output) as an edge would, print each pulse and any "
      "gaps in seq");
  listen->add_option("--port", l->port, "UDP port to listen on (0 = any free port, printed)")->required();
  listen->add_option("--bind", l->bind, "Address to bind (default 127.0.0.1)");
  listen->add_option("--count", l->count, "Stop after this many pulses (default: no limit)");
  listen->add_option("--timeout", l->timeout_s, "Stop after this many seconds without a datagram (default 5)")
      ->check(CLI::PositiveNumber);
  listen->add_flag("--quiet", l->quiet, "Print only the summary");
  listen->callback([l] { run_listen(*l); });
}

}  // namespace vc::cli
