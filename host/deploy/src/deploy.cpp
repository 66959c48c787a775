// voxcap deploy: the per-board steps as sh scripts sent over ssh, their outputs parsed as key=value
// lines, rollback from the copies the install step keeps in /var/lib/voxcap/deploy.
#include "voxcap/deploy/deploy.hpp"

#include <fmt/core.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "voxcap/auth.h"
#include "voxcap/base/clock.hpp"
#include "voxcap/session/server.hpp"

namespace vc::deploy {
namespace {

constexpr uint16_t kDeployProofRole = 3;  // voxcap-edge --prove-key (edge/daemon/main.cpp)
constexpr const char* kPackageName = "voxcap-edge";

std::string hex(const uint8_t* p, size_t n) {
  std::string s;
  for (size_t i = 0; i < n; ++i) s += fmt::format("{:02x}", p[i]);
  return s;
}

bool unhex(const std::string& s, uint8_t* out, size_t n) {
  if (s.size() != 2 * n) return false;
  for (size_t i = 0; i < n; ++i) {
    unsigned v = 0;
    for (int k = 0; k < 2; ++k) {
      const char c = s[2 * i + static_cast<size_t>(k)];
      const int d = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
      if (d < 0) return false;
      v = v * 16 + static_cast<unsigned>(d);
    }
    out[i] = static_cast<uint8_t>(v);
  }
  return true;
}

// 'text' for sh: single quotes, a quote as '\''.
std::string q(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string o;
  o.reserve(in.size() / 3 * 4 + in.size() / 57 + 8);
  size_t col = 0;
  for (size_t i = 0; i < in.size(); i += 3) {
    const uint32_t b0 = static_cast<uint8_t>(in[i]);
    const uint32_t b1 = i + 1 < in.size() ? static_cast<uint8_t>(in[i + 1]) : 0;
    const uint32_t b2 = i + 2 < in.size() ? static_cast<uint8_t>(in[i + 2]) : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    o += t[(v >> 18) & 63];
    o += t[(v >> 12) & 63];
    o += i + 1 < in.size() ? t[(v >> 6) & 63] : '=';
    o += i + 2 < in.size() ? t[v & 63] : '=';
    if (++col == 19) o += '\n', col = 0;  // 76 characters a line
  }
  return o + "\n";
}

std::map<std::string, std::string> fields(const std::string& out) {
  std::map<std::string, std::string> m;
  std::istringstream is(out);
  std::string line;
  while (std::getline(is, line)) {
    const size_t eq = line.find('=');
    if (eq != std::string::npos && line.find(' ') > eq) m[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return m;
}

std::string last_line(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  const size_t nl = s.rfind('\n');
  return nl == std::string::npos ? s : s.substr(nl + 1);
}

// The variables every script starts with: the board's layout.
std::string prelude(const BoardSettings& s) {
  return fmt::format(
      "ROOT={}\nSVC={}\nSU={}\nDPKG={}\nSYSTEMCTL={}\n"
      "ETC=\"$ROOT/etc/voxcap\"\nSTATE=\"$ROOT/var/lib/voxcap/deploy\"\nBIN=\"$ROOT/usr/bin/voxcap-edge\"\n",
      q(s.root), q(s.service), q(s.service_user), q(s.dpkg), q(s.systemctl));
}

std::string probe_script(const BoardSettings& s) {
  return prelude(s) +
         "if [ -x \"$BIN\" ]; then v=$(\"$BIN\" --version 2>/dev/null | head -n 1); echo \"version=${v##* "
         "}\";"
         " else echo version=none; fi\n"
         "echo \"active=$($SYSTEMCTL is-active \"$SVC\" 2>/dev/null | head -n 1)\"\n"
         "[ -f \"$STATE/current.deb\" ] && echo kept=yes || echo kept=no\n";
}

struct Payload {
  std::string edge_toml;
  std::string key_hex;       // "" = keyless rig
  std::string next_key_hex;  // --rotate-key: the new key, beside the old as rig.key.next; "" = none
  std::string deb;           // "" = no package this run
};

std::string install_script(const BoardSettings& s, const Payload& p, const std::string& eof) {
  std::string o = prelude(s) + "set -eu\numask 077\nmkdir -p \"$ETC\" \"$STATE\"\n";
  // What runs now, kept for the rollback.
  o += "rm -f \"$STATE/edge.toml.prev\" \"$STATE/rig.key.prev\" \"$STATE/rig.key.next.prev\"\n"
       "[ ! -f \"$ETC/edge.toml\" ] || cp -p \"$ETC/edge.toml\" \"$STATE/edge.toml.prev\"\n"
       "[ ! -f \"$ETC/rig.key\" ] || cp -p \"$ETC/rig.key\" \"$STATE/rig.key.prev\"\n"
       "[ ! -f \"$ETC/rig.key.next\" ] || cp -p \"$ETC/rig.key.next\" \"$STATE/rig.key.next.prev\"\n";
  if (!p.deb.empty())
    o += "rm -f \"$STATE/previous.deb\"\n[ ! -f \"$STATE/current.deb\" ] || cp -p \"$STATE/current.deb\" "
         "\"$STATE/previous.deb\"\n";
  o += "echo step=saved\n";
  // The new files under temporary names, then renamed: the board never holds half a file, and the key
  // file is never absent or open to others (umask 077, 0600, the service user's).
  o += "cat > \"$ETC/.edge.toml.new\" <<'" + eof + "'\n" + p.edge_toml +
       (p.edge_toml.empty() || p.edge_toml.back() == '\n' ? "" : "\n") + eof + "\n";
  o += "chmod 644 \"$ETC/.edge.toml.new\"\n";
  if (!p.key_hex.empty()) {
    o += "printf '%s\\n' " + q(p.key_hex) +
         " > \"$ETC/.rig.key.new\"\n"
         "chmod 600 \"$ETC/.rig.key.new\"\n"
         "chown \"$SU\" \"$ETC/.rig.key.new\" || { echo fail=key-owner; exit 12; }\n"
         "mv -f \"$ETC/.rig.key.new\" \"$ETC/rig.key\"\n";
  }
  // A rotation: the new key beside the old one (edge.toml names both, the node proves either); any
  // other deploy leaves one key, so a finished rotation's old key goes here.
  if (!p.next_key_hex.empty())
    o += "printf '%s\\n' " + q(p.next_key_hex) +
         " > \"$ETC/.rig.key.next.new\"\n"
         "chmod 600 \"$ETC/.rig.key.next.new\"\n"
         "chown \"$SU\" \"$ETC/.rig.key.next.new\" || { echo fail=key-owner; exit 12; }\n"
         "mv -f \"$ETC/.rig.key.next.new\" \"$ETC/rig.key.next\"\n";
  o += "mv -f \"$ETC/.edge.toml.new\" \"$ETC/edge.toml\"\n";
  if (p.next_key_hex.empty()) o += "rm -f \"$ETC/rig.key.next\"\n";
  o += "echo step=config\n";
  if (!p.deb.empty()) {
    o += "base64 -d > \"$STATE/new.deb\" <<'" + eof + "'\n" + base64(p.deb) + eof + "\n";
    // --force-confold: an edge.toml the package ships as a conffile stays the one written above,
    // without a question no one is there to answer.
    o += "export DEBIAN_FRONTEND=noninteractive\n";
    o += "if ! $DPKG --force-confold -i \"$STATE/new.deb\" > \"$STATE/dpkg.log\" 2>&1; then\n"
         "  tail -n 3 \"$STATE/dpkg.log\" | sed 's/^/dpkg: /'; echo fail=install; exit 10\nfi\n"
         "mv -f \"$STATE/new.deb\" \"$STATE/current.deb\"\necho step=installed\n";
  }
  o += "$SYSTEMCTL restart \"$SVC\" || { echo fail=restart; exit 11; }\necho step=restarted\n";
  return o;
}

std::string rollback_script(const BoardSettings& s, bool package) {
  std::string o = prelude(s) + "umask 077\n";
  if (package)
    o += "if [ -f \"$STATE/previous.deb\" ]; then\n"
         "  if DEBIAN_FRONTEND=noninteractive $DPKG --force-confold -i \"$STATE/previous.deb\" > "
         "\"$STATE/dpkg.log\" 2>&1; then cp -p \"$STATE/previous.deb\" "
         "\"$STATE/current.deb\"; echo package=restored; else echo package=failed; fi\n"
         "else echo package=none-kept; fi\n";
  o += "rm -f \"$ETC/.edge.toml.new\" \"$ETC/.rig.key.new\" \"$ETC/.rig.key.next.new\"\n";
  o +=
      "[ ! -f \"$STATE/edge.toml.prev\" ] || cp -p \"$STATE/edge.toml.prev\" \"$ETC/edge.toml\"\n"
      "[ ! -f \"$STATE/rig.key.prev\" ] || cp -p \"$STATE/rig.key.prev\" \"$ETC/rig.key\"\n"
      "if [ -f \"$STATE/rig.key.next.prev\" ]; then cp -p \"$STATE/rig.key.next.prev\" \"$ETC/rig.key.next\";"
      " else rm -f \"$ETC/rig.key.next\"; fi\n"
      "echo config=restored\n"
      "$SYSTEMCTL restart \"$SVC\" && echo restart=ok || echo restart=failed\n";
  return o;
}

std::string verify_script(const BoardSettings& s, const std::string& nonce_hex) {
  return prelude(s) + fmt::format("sleep {}\n", s.settle_s) +
         "echo \"active=$($SYSTEMCTL is-active \"$SVC\" 2>/dev/null | head -n 1)\"\n"
         "if [ -x \"$BIN\" ]; then v=$(\"$BIN\" --version 2>/dev/null | head -n 1); echo \"version=${v##* "
         "}\";"
         " else echo version=none; fi\n"
         "\"$BIN\" --config \"$ETC/edge.toml\" --prove-key " +
         nonce_hex + " 2>&1 | tail -n 2 | sed 's/^/proof_line=/'\n";
}

struct Verified {
  bool active = false;
  std::string version;
  KeyState key = KeyState::Unknown;
  std::string why;
};

// Runs the verify script and judges it against the keys deploy holds.
Verified verify(Remote& remote, const Board& b, const std::vector<uint8_t>& key_now,
                const std::vector<uint8_t>& key_old, bool rotating) {
  Verified v;
  uint8_t nonce[VC_AUTH_NONCE_SIZE];
  vc_auth_random(nonce, sizeof nonce);
  const ProcessResult r = remote.run(b, verify_script(b.settings, hex(nonce, sizeof nonce)), true);
  if (r.exit_code != 0) {
    v.why = r.why.empty() ? "verify: " + last_line(r.err + r.out) : r.why;
    return v;
  }
  auto f = fields(r.out);
  v.active = f["active"] == "active";
  v.version = f["version"];
  if (key_now.empty()) {
    v.key = KeyState::Current;  // a keyless rig: nothing to prove
    return v;
  }
  // One "node_id=N nonce=HEX proof=HEX" line per key the board holds (two while a rotation is under
  // way: its key and, marked key=next, the next one).
  bool any = false, proves_now = false, proves_old = false;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("proof_line=", 0) != 0) continue;
    std::map<std::string, std::string> p;
    std::istringstream is(line.substr(11));
    std::string w;
    while (is >> w)
      if (const size_t eq = w.find('='); eq != std::string::npos) p[w.substr(0, eq)] = w.substr(eq + 1);
    uint8_t theirs[VC_AUTH_NONCE_SIZE], proof[VC_AUTH_PROOF_SIZE];
    if (p["node_id"] != std::to_string(b.number) || !unhex(p["nonce"], theirs, sizeof theirs) ||
        !unhex(p["proof"], proof, sizeof proof))
      continue;
    any = true;
    proves_now =
        proves_now || vc_auth_verify(proof, key_now.data(), kDeployProofRole, b.number, theirs, nonce);
    proves_old = proves_old || (!key_old.empty() && vc_auth_verify(proof, key_old.data(), kDeployProofRole,
                                                                   b.number, theirs, nonce));
  }
  if (!any)
    v.why = "no key proof: " + (f["proof_line"].empty() ? std::string("(nothing)") : f["proof_line"]);
  else if (proves_now)
    v.key = rotating ? KeyState::New : KeyState::Current;
  else if (proves_old)
    v.key = KeyState::Old;
  else
    v.why = "it proves another rig key";
  return v;
}

// HELLO's check (issue #16 item 4): while no voxcap-host holds the rig's port, deploy listens there
// with the host's own session server (host/session: the same HELLO gate and key handshake, proved
// with the key the host holds) and notes every node's HELLO: its software version, once it proved
// the key. The connections stay open until deploy ends; the edges then reconnect with backoff and
// join the real host when it starts.
class HelloWatch : public session::Handler {
 public:
  struct Seen {
    uint64_t t_ns = 0;
    std::string version;  // sw_major.sw_minor.sw_patch
    bool proved = false;  // it proved the rig key (a keyed rig only accepts such a HELLO)
  };

  HelloWatch(const config::RigConfig& rig, std::vector<uint8_t> host_key) {
    session::ServerOptions so;
    so.listen = rig.network.listen;
    so.port = rig.network.port;
    so.heartbeat_interval_ms = rig.network.heartbeat_interval_ms;  // as the host would watch the boards
    so.heartbeat_timeout_ms = rig.network.heartbeat_timeout_ms;
    so.key = std::move(host_key);
    keyed_ = !so.key.empty();
    server_ = std::make_unique<session::Server>(so, *this, [](log::Level, const std::string&) {});
  }
  ~HelloWatch() override { stop(); }
  HelloWatch(const HelloWatch&) = delete;
  HelloWatch& operator=(const HelloWatch&) = delete;

  void start() { server_->start(); }  // throws std::runtime_error (the port is taken)
  void stop() {
    if (server_) server_->stop();
  }

  // A HELLO of node since since_ns saying version want, waiting at most timeout_s; else the last HELLO
  // it sent since (the process before the restart may still have said one), else none.
  std::optional<Seen> wait(uint16_t node, uint64_t since_ns, const std::string& want, int timeout_s) {
    std::unique_lock<std::mutex> g(mu_);
    std::optional<Seen> found;
    cv_.wait_for(g, std::chrono::seconds(timeout_s), [&] {
      for (const auto& [n, seen] : hellos_)
        if (n == node && seen.t_ns >= since_ns) {
          found = seen;
          if (seen.version == want) return true;
        }
      return false;
    });
    return found;
  }

  std::string on_hello(session::ConnId, const vc_msg& m, const std::string&) override {
    Seen s;
    s.t_ns = monotonic_ns();
    s.version = fmt::format("{}.{}.{}", m.u.hello.sw_major, m.u.hello.sw_minor, m.u.hello.sw_patch);
    s.proved = keyed_;  // a keyed server hands over a HELLO only once its sender proved the key
    {
      std::lock_guard<std::mutex> g(mu_);
      if (hellos_.size() < 4096) hellos_.emplace_back(m.u.hello.node_id, s);  // bounded
    }
    cv_.notify_all();
    return "";
  }
  void on_message(session::ConnId, const vc_msg&, uint64_t) override {}
  void on_disconnect(session::ConnId, const std::string&) override {}

 private:
  std::unique_ptr<session::Server> server_;
  bool keyed_ = false;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::pair<uint16_t, Seen>> hellos_;
};

// Whether address (what the boards connect to) is one of this machine's: a socket binds to it. A rig
// whose host listens on "any" from another machine must not have deploy wait for HELLOs that go there.
bool local_address(const std::string& address) {
  addrinfo hints{};
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (address.empty() || ::getaddrinfo(address.c_str(), "0", &hints, &res) != 0) return false;
  bool local = false;
  for (const addrinfo* a = res; a && !local; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd < 0) continue;
    local = ::bind(fd, a->ai_addr, a->ai_addrlen) == 0;
    ::close(fd);
  }
  ::freeaddrinfo(res);
  return local;
}

std::vector<uint8_t> load_key(const std::filesystem::path& p) {
  std::vector<uint8_t> k(VC_AUTH_KEY_SIZE);
  char why[512];
  if (vc_key_load(p.c_str(), k.data(), why, sizeof why) < 0) throw InventoryError(why);
  return k;
}

std::string read_file(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  if (!f) throw InventoryError(fmt::format("{}: cannot read", p.string()));
  std::ostringstream os;
  os << f.rdbuf();
  return os.str();
}

}  // namespace

bool DeployOptions::valid(std::string* why) const {
  if (!package.empty() && package.extension() != ".deb") {
    if (why) *why = "--package: expected a .deb file, got " + package.string();
    return false;
  }
  return true;
}

bool DeployReport::ok() const {
  return std::all_of(boards.begin(), boards.end(), [](const BoardResult& b) { return b.ok; }) &&
         left_with_old_key.empty();
}

std::string upstream_version(const std::string& v) {
  std::string s = v;
  if (const size_t c = s.find(':'); c != std::string::npos) s = s.substr(c + 1);
  if (const size_t d = s.rfind('-'); d != std::string::npos) s = s.substr(0, d);
  return s;
}

PackageInfo read_package(const std::filesystem::path& deb) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(deb, ec))
    throw InventoryError(fmt::format("{}: no such package file", deb.string()));
  const ProcessResult r = run_process({"dpkg-deb", "-f", deb.string(), "Package", "Version"}, "", 60);
  if (r.exit_code != 0)
    throw InventoryError(
        fmt::format("{}: not a Debian package ({})", deb.string(), r.why.empty() ? last_line(r.err) : r.why));
  PackageInfo p;
  std::istringstream is(r.out);
  std::string line;
  while (std::getline(is, line)) {
    if (line.rfind("Package: ", 0) == 0) p.name = line.substr(9);
    if (line.rfind("Version: ", 0) == 0) p.version = line.substr(9);
  }
  if (p.name != kPackageName)
    throw InventoryError(fmt::format("{}: package {}, expected {}", deb.string(), p.name, kPackageName));
  p.upstream = upstream_version(p.version);
  if (p.upstream.empty()) throw InventoryError(fmt::format("{}: no version", deb.string()));
  return p;
}

DeployReport run_deploy(const Inventory& inv, const DeployOptions& opt, Remote& remote,
                        const Progress& progress) {
  std::string why;
  if (!opt.valid(&why)) throw InventoryError(why);
  if (vc_auth_init() < 0) throw std::runtime_error("libsodium failed to start");
  DeployReport report;

  std::vector<const Board*> boards;
  for (const Board& b : inv.boards)
    if (opt.nodes.empty() || std::find(opt.nodes.begin(), opt.nodes.end(), b.id) != opt.nodes.end())
      boards.push_back(&b);
  for (const std::string& n : opt.nodes)
    if (!inv.board(n))
      throw InventoryError(fmt::format("--node {}: no such node in {}", n, inv.rig.source.string()));

  const std::filesystem::path package = opt.package.empty() ? inv.package : opt.package;
  Payload base;
  if (!package.empty()) {
    const PackageInfo info = read_package(package);
    report.package_version = info.upstream;
    base.deb = opt.dry_run ? std::string() : read_file(package);
    progress("", fmt::format("package {} {} ({})", info.name, info.version, package.string()));
  }

  // The keys: the rig's, and with --rotate-key the new one, kept beside it as <key>.next until every
  // board proved it (a rerun after a partial failure takes the same new key).
  std::vector<uint8_t> key_now, key_old;
  if (!inv.rig.key_path.empty()) key_now = load_key(inv.rig.key_path);
  if (opt.rotate_key) {
    if (inv.rig.key_path.empty())
      throw InventoryError(inv.rig.source.string() + ": key: --rotate-key needs a keyed rig");
    report.key_next = inv.rig.key_path;
    report.key_next += ".next";
    key_old = key_now;
    std::error_code ec;
    if (std::filesystem::exists(report.key_next, ec)) {
      key_now = load_key(report.key_next);
      progress("", fmt::format("rotating to the pending new key {}", report.key_next.string()));
    } else if (!opt.dry_run) {
      key_now.assign(VC_AUTH_KEY_SIZE, 0);
      char w[512];
      if (vc_key_write(report.key_next.c_str(), false, key_now.data(), w, sizeof w) < 0)
        throw InventoryError(w);
      progress("", fmt::format("new rig key written to {} (mode 0600)", report.key_next.string()));
    }
  }
  // The board's rig.key is the host's key; during a rotation the new one goes beside it (next_key).
  const std::vector<uint8_t>& host_key = opt.rotate_key ? key_old : key_now;
  if (!host_key.empty()) base.key_hex = hex(host_key.data(), host_key.size());
  if (opt.rotate_key && !key_now.empty()) base.next_key_hex = hex(key_now.data(), key_now.size());

  std::unique_ptr<HelloWatch> watch;
  const std::string rig_port = fmt::format("{}:{}", inv.rig.network.listen, inv.rig.network.port);
  if (!opt.dry_run && inv.hello_timeout_s > 0 && !local_address(inv.host_address)) {
    report.hello_note = fmt::format(
        "HELLO not checked: the boards connect to {}, not an address of this machine", inv.host_address);
    progress("", report.hello_note);
  } else if (!opt.dry_run && inv.hello_timeout_s > 0) {
    try {
      watch = std::make_unique<HelloWatch>(inv.rig, host_key);
      watch->start();
      report.hello_note = "listened on the rig's port " + rig_port + " for the boards' HELLO";
    } catch (const std::exception& e) {
      watch.reset();
      report.hello_note = fmt::format(
          "HELLO not checked: the rig's port {} is taken (voxcap-host runs?) or not this machine's ({})",
          rig_port, e.what());
    }
    progress("", report.hello_note);
  }

  report.boards.resize(boards.size());
  std::atomic<size_t> next{0};
  auto work = [&](size_t i) {
    const Board& b = *boards[i];
    BoardResult& res = report.boards[i];
    res.id = b.id;
    auto say = [&](const std::string& line) { progress(b.id, line); };
    say("connecting to " + b.settings.ssh);
    ProcessResult pr = remote.run(b, probe_script(b.settings), false);
    if (pr.exit_code != 0) {
      res.why = pr.why.empty() ? "probe: " + last_line(pr.err + pr.out) : pr.why;
      say("FAILED: " + res.why);
      return;
    }
    auto pf = fields(pr.out);
    res.before = pf["version"].empty() ? "none" : pf["version"];
    say(fmt::format("runs voxcap-edge {} (service {}){}", res.before,
                    pf["active"].empty() ? "unknown" : pf["active"],
                    pf["kept"] == "yes" ? "" : ", no package kept for a rollback"));
    const std::string want = report.package_version.empty() ? res.before : report.package_version;
    if (opt.dry_run) {
      say(fmt::format("would {} voxcap-edge {}, write edge.toml{}, restart {}",
                      report.package_version.empty() ? "keep" : "install", want,
                      key_now.empty() ? "" : (opt.rotate_key ? " and the NEW rig key" : " and the rig key"),
                      b.settings.service));
      res.ok = true;
      res.after = res.before;
      return;
    }
    Payload p = base;
    p.edge_toml = b.edge_toml;
    if (!p.next_key_hex.empty()) p.edge_toml = "next_key = 'rig.key.next'\n" + p.edge_toml;
    uint8_t r8[8];
    vc_auth_random(r8, sizeof r8);
    const std::string eof = "VOXCAP_EOF_" + hex(r8, sizeof r8);
    say(report.package_version.empty() ? "writing edge.toml and the rig key, restarting"
                                       : "installing voxcap-edge " + report.package_version);
    const uint64_t t_install = monotonic_ns();
    const ProcessResult ir = remote.run(b, install_script(b.settings, p, eof), true);
    bool failed = ir.exit_code != 0;
    if (failed) {
      auto f = fields(ir.out);
      std::string detail;
      std::istringstream is(ir.out);
      for (std::string line; std::getline(is, line);)
        if (line.rfind("dpkg: ", 0) == 0) detail = line;
      res.why = !ir.why.empty() ? ir.why
                : f.count("fail")
                    ? fmt::format("{} failed{}", f["fail"], detail.empty() ? "" : " (" + detail + ")")
                    : "install: " + last_line(ir.err + ir.out);
    } else {
      const Verified v = verify(remote, b, key_now, key_old, opt.rotate_key);
      res.after = v.version;
      res.key = v.key;
      if (!v.why.empty())
        res.why = v.why, failed = true;
      else if (!v.active)
        res.why = "the service is not active after the restart", failed = true;
      else if (v.version != want)
        res.why = fmt::format("it runs {} after the restart, not {}",
                              v.version.empty() ? "nothing" : v.version, want),
        failed = true;
      else if (v.key == KeyState::Old)
        res.why = "it still proves the old key", failed = true;
    }
    if (!failed && watch) {
      // The node must come back to the rig: a HELLO since the restart, with the version asked for.
      say(fmt::format("waiting for its HELLO on {} (at most {} s)", rig_port, inv.hello_timeout_s));
      const auto seen = watch->wait(b.number, t_install, want, inv.hello_timeout_s);
      if (!seen) {
        res.why =
            fmt::format("it did not rejoin the rig (no HELLO on {} in {} s)", rig_port, inv.hello_timeout_s);
        failed = true;
      } else {
        res.hello = seen->version;
        if (seen->version != want)
          res.why = fmt::format("it rejoined with {} (HELLO), not {}", seen->version, want), failed = true;
      }
    }
    if (!failed) {
      res.ok = true;
      say(fmt::format("ok: voxcap-edge {} active{}{}", res.after,
                      key_now.empty() ? ""
                      : opt.rotate_key
                          ? ", proved the NEW key (and holds the old one until the host switches)"
                          : ", proved the rig key",
                      res.hello.empty() ? ""
                                        : fmt::format(", rejoined with {} (HELLO{})", res.hello,
                                                      host_key.empty() ? "" : ", key proved")));
      return;
    }
    say("FAILED: " + res.why + "; rolling back");
    res.rolled_back = true;
    const ProcessResult rr = remote.run(b, rollback_script(b.settings, !p.deb.empty()), true);
    auto rf = fields(rr.out);
    if (rr.exit_code != 0) {
      say("rollback failed: " + (rr.why.empty() ? last_line(rr.err + rr.out) : rr.why));
      return;
    }
    if (rf["package"] == "none-kept")
      say("no previous package was kept on the board: only its configuration restored");
    if (rf["package"] == "failed")
      say("reinstalling the previous package failed (see /var/lib/voxcap/deploy/dpkg.log)");
    const Verified v = verify(remote, b, key_old.empty() ? key_now : key_old, key_now, false);
    res.after = v.version;
    // After a rollback of a rotation, "current" means the old key and "old" the new one.
    res.key = !opt.rotate_key              ? v.key
              : v.key == KeyState::Current ? KeyState::Old
              : v.key == KeyState::Old     ? KeyState::New
                                           : v.key;
    res.rollback_ok = v.active && v.version == res.before && v.why.empty();
    say(fmt::format(
        "rolled back: voxcap-edge {} {}", v.version.empty() ? "none" : v.version,
        res.rollback_ok
            ? "active again"
            : "NOT back as before (" +
                  (v.why.empty() ? "service " + std::string(v.active ? "active" : "inactive") : v.why) +
                  ")"));
  };
  const size_t n_threads = std::min<size_t>(static_cast<size_t>(inv.parallel), boards.size());
  std::vector<std::thread> pool;
  for (size_t t = 0; t < n_threads; ++t)
    pool.emplace_back([&] {
      for (size_t i = next++; i < boards.size(); i = next++) work(i);
    });
  for (auto& t : pool) t.join();
  if (watch) watch->stop();  // the edges reconnect with backoff and join the real host

  if (opt.rotate_key && !opt.dry_run) {
    for (const BoardResult& r : report.boards)
      if (r.key != KeyState::New) report.left_with_old_key.push_back(r.id);
    if (report.left_with_old_key.empty() && opt.nodes.empty()) {
      // Every board proved the new key: the host takes it (the old one kept as <key>.old).
      std::filesystem::path old = inv.rig.key_path;
      old += ".old";
      std::error_code ec;
      std::filesystem::copy_file(inv.rig.key_path, old, std::filesystem::copy_options::overwrite_existing,
                                 ec);
      if (!ec)
        std::filesystem::permissions(
            old, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write, ec);
      std::filesystem::rename(report.key_next, inv.rig.key_path, ec);
      if (ec)
        throw std::runtime_error(
            fmt::format("{}: cannot take the new key: {}", inv.rig.key_path.string(), ec.message()));
      report.key_switched = true;
      progress("", fmt::format("every board proved the new key: {} now holds it (the old one in {}); restart "
                               "voxcap-host so it uses it (the boards take either key meanwhile), then run "
                               "voxcap deploy to drop the old key from them",
                               inv.rig.key_path.string(), old.string()));
    } else if (report.left_with_old_key.empty()) {
      progress("", "--node chose some boards: the host keeps its key; rotate every board to switch it");
    }
  }
  return report;
}

std::string format_summary(const DeployReport& r, bool rotate_key) {
  std::string o = fmt::format("{:<16} {:<10} {:<10} {:<6} {:<10} {}\n", "board", "before", "after", "key",
                              "HELLO", "result");
  size_t good = 0;
  for (const BoardResult& b : r.boards) {
    const char* key = b.key == KeyState::New       ? "new"
                      : b.key == KeyState::Old     ? "OLD"
                      : b.key == KeyState::Current ? "ok"
                                                   : "?";
    std::string result = b.ok ? "ok"
                         : b.rolled_back
                             ? (b.rollback_ok ? "FAILED, rolled back" : "FAILED, rollback incomplete")
                             : "FAILED";
    if (!b.ok) result += ": " + b.why;
    o += fmt::format("{:<16} {:<10} {:<10} {:<6} {:<10} {}\n", b.id, b.before.empty() ? "?" : b.before,
                     b.after.empty() ? "?" : b.after, key, b.hello.empty() ? "-" : b.hello, result);
    good += b.ok ? 1 : 0;
  }
  o += fmt::format("{} of {} boards ok", good, r.boards.size());
  if (!r.package_version.empty()) o += fmt::format(" (voxcap-edge {})", r.package_version);
  o += "\n";
  if (!r.hello_note.empty()) o += r.hello_note + "\n";
  if (rotate_key) {
    if (r.key_switched)
      o += "rig key rotated: every board proved the new key; restart voxcap-host (the boards take either key "
           "until then), then run voxcap deploy to drop the old key from the boards\n";
    else if (!r.left_with_old_key.empty()) {
      o += "rig key NOT rotated on the host; boards without the new key:";
      for (const auto& id : r.left_with_old_key) o += " " + id;
      o += fmt::format("\n(the new key waits in {}; fix them and run voxcap deploy --rotate-key again)\n",
                       r.key_next.string());
    }
  }
  return o;
}

}  // namespace vc::deploy
