// voxcap deploy over real ssh (issue #16): an OpenSSH server the test starts on 127.0.0.1 (a free
// port, its own host key, authorized_keys and known_hosts in a temporary folder, the same user) stands
// in for the boards. Each "board" is a folder (the inventory's [nodes.deploy] root) with stand-ins for
// dpkg (dpkg-deb -x into the folder) and systemctl (restart: "active" when the installed voxcap-edge
// answers --version); the package is a real .deb (dpkg-deb --build) whose voxcap-edge runs this build's
// voxcap-edge, so --version and --prove-key are the real daemon's. The test runs the `voxcap deploy`
// binary and checks the boards' files and the summary: an upgrade, a failing installer and a version
// that never comes up (both rolled back and named), key rotation (every board proves the new key; a
// board that cannot take it is named and the host keeps its key). Loopback only; every wait bounded.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void put(const fs::path& p, const std::string& text,
         fs::perms mode = fs::perms::owner_read | fs::perms::owner_write) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
  fs::permissions(p, mode);
}

const fs::perms kExec = fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                        fs::perms::others_read | fs::perms::others_exec;

struct CmdResult {
  int code = -1;
  std::string out;
};

CmdResult sh(const std::string& cmd) {
  CmdResult r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = ::pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

int free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = -1;
  if (::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    port = ntohs(a.sin_port);
  ::close(s);
  return port;
}

bool accepts(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

class DeploySsh : public ::testing::Test {
 protected:
  fs::path dir;
  int port = -1;
  pid_t sshd = -1;
  int rig_port = -1;  // the rig's host port: deploy's HELLO listener, the daemons' host.port
  std::string user;

  void SetUp() override {
    const char* sshd_bin = "/usr/sbin/sshd";
    if (::access(sshd_bin, X_OK) != 0)
      GTEST_SKIP() << "no /usr/sbin/sshd: install openssh-server (deploy/install-deps.sh)";
    if (sh("command -v ssh && command -v ssh-keygen && command -v dpkg-deb").code != 0)
      GTEST_SKIP() << "ssh, ssh-keygen or dpkg-deb missing (openssh-client, dpkg)";
    const passwd* pw = ::getpwuid(::getuid());
    ASSERT_NE(pw, nullptr);
    user = pw->pw_name;
    dir = fs::temp_directory_path() / ("vc_deploy_ssh_" + std::to_string(::getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    fs::permissions(dir, fs::perms::owner_all);
    ASSERT_EQ(sh("ssh-keygen -q -t ed25519 -N '' -f " + (dir / "hostkey").string()).code, 0);
    ASSERT_EQ(sh("ssh-keygen -q -t ed25519 -N '' -f " + (dir / "userkey").string()).code, 0);
    put(dir / "authorized_keys", slurp(dir / "userkey.pub"));
    if (::getuid() == 0) fs::create_directories("/run/sshd");  // sshd's privilege separation folder
    port = free_port();
    ASSERT_GT(port, 0);
    put(dir / "sshd_config",
        "Port " + std::to_string(port) + "\nListenAddress 127.0.0.1\nHostKey " + (dir / "hostkey").string() +
            "\nAuthorizedKeysFile " + (dir / "authorized_keys").string() + "\nPidFile " +
            (dir / "sshd.pid").string() + "\nAllowUsers " + user +
            "\nStrictModes no\nUsePAM no\nPasswordAuthentication no\nKbdInteractiveAuthentication no\n"
            "PubkeyAuthentication yes\nPermitRootLogin prohibit-password\nLogLevel ERROR\nMaxStartups 30\n");
    // known_hosts: this server's key for [127.0.0.1]:port, so StrictHostKeyChecking=yes passes.
    const std::string hostpub = slurp(dir / "hostkey.pub");
    put(dir / "known_hosts",
        "[127.0.0.1]:" + std::to_string(port) + " " + hostpub.substr(0, hostpub.rfind(' ')) + "\n");
    sshd = ::fork();
    if (sshd == 0) {
      ::execl(sshd_bin, sshd_bin, "-D", "-e", "-f", (dir / "sshd_config").c_str(), nullptr);
      ::_exit(127);
    }
    ASSERT_GT(sshd, 0);
    bool up = false;
    for (int i = 0; i < 100 && !up; ++i) {  // at most 10 s
      up = accepts(port);
      if (!up) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_TRUE(up) << "sshd did not start on 127.0.0.1:" << port;

    // The board's stand-ins: dpkg and systemctl take the board's folder as their first argument.
    put(dir / "bin" / "fake-dpkg",
        "#!/bin/sh\n# fake-dpkg ROOT -i FILE: unpack into the board's folder, as dpkg -i would install\n"
        "root=$1; shift; while [ $# -gt 0 ] && [ \"$1\" != -i ]; do shift; done; [ \"$1\" = -i ] || exit 2\n"
        "dpkg-deb -x \"$2\" \"$root\" || exit 1\n"
        "dpkg-deb -f \"$2\" Version > \"$root/installed-version\"\n",
        kExec);
    put(dir / "bin" / "fail-dpkg",
        "#!/bin/sh\necho \"dpkg: error processing archive $4 (--install): installed voxcap-edge package "
        "post-installation script subprocess returned error exit status 1\" >&2\nexit 1\n",
        kExec);
    // Takes any package but one of version 0.2: "succeeds" without installing it (a board where the new
    // version never comes up).
    put(dir / "bin" / "stale-dpkg",
        "#!/bin/sh\nroot=$1; shift\nfor f; do :; done\ndpkg-deb -f \"$f\" Version | grep -q '^0\\.2' && exit "
        "0\n"
        "exec " +
            (dir / "bin" / "fake-dpkg").string() + " \"$root\" \"$@\"\n",
        kExec);
    // restart: stops the board's running voxcap-edge (its pid file), then starts the installed one
    // with the board's edge.toml in the background, as the unit would: a real daemon that connects to
    // the rig's port and says HELLO (not when the board folder holds "no-daemon": a service that looks
    // active but never joins the rig).
    put(dir / "bin" / "fake-systemctl",
        "#!/bin/sh\n# fake-systemctl ROOT restart|is-active UNIT\nroot=$1; shift\n"
        "case \"$1\" in\n"
        "  restart) mkdir -p \"$root/run\"; rm -f \"$root/run/active\"; echo \"$2\" >> "
        "\"$root/run/restarts\"\n"
        "    if [ -f \"$root/run/pid\" ]; then p=$(cat \"$root/run/pid\"); kill \"$p\" 2>/dev/null; i=0\n"
        "      while kill -0 \"$p\" 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i+1)); done\n"
        "      kill -9 \"$p\" 2>/dev/null; rm -f \"$root/run/pid\"; fi\n"
        "    \"$root/usr/bin/voxcap-edge\" --version > /dev/null 2>&1 || exit 0\n"
        "    touch \"$root/run/active\"\n"
        "    if [ -f \"$root/etc/voxcap/edge.toml\" ] && [ ! -f \"$root/no-daemon\" ]; then\n"
        "      setsid \"$root/usr/bin/voxcap-edge\" --config \"$root/etc/voxcap/edge.toml\" < /dev/null >> "
        "\"$root/run/edge.log\" 2>&1 &\n"
        "      echo $! > \"$root/run/pid\"\n    fi\n    exit 0;;\n"
        "  is-active) if [ -f \"$root/run/active\" ]; then echo active; else echo failed; exit 3; fi;;\n"
        "  *) exit 2;;\nesac\n",
        kExec);
    rig_port = free_port();
    ASSERT_GT(rig_port, 0);
    ASSERT_EQ(sh(std::string(VOXCAP_BINARY) + " key new " + (dir / "rig.key").string()).code, 0);
    fs::copy_file(fs::path(VOXCAP_SOURCE_DIR) / "hw" / "rigs" / "emulated.yaml", dir / "emulated.yaml");
    package("0.1.0-1", "");
  }

  void TearDown() override {
    // The boards' daemons (started through ssh, so not our children): by their pid files, bounded.
    for (const std::string id : {"node1", "node2", "node3"}) {
      const fs::path pidfile = dir / ("board-" + id) / "run" / "pid";
      if (dir.empty() || !fs::exists(pidfile)) continue;
      const pid_t p = static_cast<pid_t>(std::stol("0" + slurp(pidfile)));
      if (p <= 1) continue;
      ::kill(p, SIGTERM);
      for (int i = 0; i < 50 && ::kill(p, 0) == 0; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      ::kill(p, SIGKILL);
    }
    if (sshd > 0) {
      ::kill(sshd, SIGTERM);
      int st = 0;
      ::waitpid(sshd, &st, 0);
    }
    if (!dir.empty() && !HasFailure()) fs::remove_all(dir);
  }

  // A voxcap-edge .deb: its binary runs this build's voxcap-edge; `version_override` makes --version
  // say another release (a package whose binary is not the version its control file says).
  fs::path package(const std::string& version, const std::string& says) {
    const fs::path stage = dir / ("pkg-" + version);
    fs::remove_all(stage);
    put(stage / "DEBIAN" / "control",
        "Package: voxcap-edge\nVersion: " + version +
            "\nArchitecture: all\nMaintainer: voxcap tests <tests@localhost>\nDescription: voxcap-edge "
            "stand-in\n",
        fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
    std::string bin = "#!/bin/sh\n";
    if (!says.empty()) bin += "[ \"$1\" = --version ] && { echo \"voxcap-edge " + says + "\"; exit 0; }\n";
    bin += std::string("exec ") + VOXCAP_EDGE_BINARY + " \"$@\"\n";
    put(stage / "usr" / "bin" / "voxcap-edge", bin, kExec);
    fs::path deb = dir / ("voxcap-edge_" + version + "_all.deb");
    const CmdResult r =
        sh("dpkg-deb --root-owner-group -Zgzip --build " + stage.string() + " " + deb.string());
    EXPECT_EQ(r.code, 0) << r.out;
    return deb;
  }

  // A board folder with an old voxcap-edge (says 0.0.9, otherwise the real daemon).
  void old_board(const std::string& id) {
    const fs::path root = dir / ("board-" + id);
    put(root / "usr" / "bin" / "voxcap-edge",
        std::string("#!/bin/sh\n[ \"$1\" = --version ] && { echo 'voxcap-edge 0.0.9'; exit 0; }\nexec ") +
            VOXCAP_EDGE_BINARY + " \"$@\"\n",
        kExec);
  }

  // The rig file: nodes node1..nodeN on loopback, each a board folder reached over the test's sshd.
  // hello_timeout_s: how long deploy waits for each board's HELLO on the rig's port (0: not at all).
  void rig(const std::vector<std::string>& ids, const std::vector<std::string>& dpkg,
           const std::vector<std::string>& service_user = {}, int hello_timeout_s = 30) {
    static const char* cams[] = {"front0", "front1", "ring2", "ring3", "ring4", "ring5"};
    std::string t =
        "version = 1\nname = \"loopback-boards\"\ncalibration = \"emulated.yaml\"\nkey = \"rig.key\"\n"
        "[grid]\nmin_m = [-1.12, -1.12, 0.0]\nvoxel_m = 0.035\nnx = 64\nny = 64\nnz = 64\n";
    for (size_t i = 0; i < ids.size(); ++i) {
      const fs::path root = dir / ("board-" + ids[i]);
      t += "[[nodes]]\nid = \"" + ids[i] + "\"\naddress = \"127.0.0.1\"\nssh = \"" + user + "@127.0.0.1\"\n";
      t += "cameras = [\"" + std::string(cams[2 * i]) + "\", \"" + cams[2 * i + 1] + "\"]\n";
      t += "deploy = { root = \"" + root.string() + "\", dpkg = \"" + (dir / "bin" / dpkg[i]).string() + " " +
           root.string() + "\", systemctl = \"" + (dir / "bin" / "fake-systemctl").string() + " " +
           root.string() + "\"" +
           (i < service_user.size() ? ", service_user = \"" + service_user[i] + "\"" : "") +
           ", edge = { trigger = { port = " + std::to_string(trigger_port(i)) + " } } }\n";
    }
    t += "[trigger]\nbackend = \"udp\"\n[trigger.udp]\ntargets = [";
    for (size_t i = 0; i < ids.size(); ++i)
      t += (i ? ", \"" : "\"") + std::string("127.0.0.1:") + std::to_string(trigger_port(i)) + "\"";
    t += "]\n[network]\nlisten = \"127.0.0.1\"\nport = " + std::to_string(rig_port) + "\n";
    t += "[deploy]\nssh_port = " + std::to_string(port) +
         "\nidentity = \"userkey\"\nknown_hosts = \"known_hosts\"\n"
         "sudo = \"\"\nservice_user = \"" +
         user +
         "\"\nsettle_s = 0\nconnect_timeout_s = 10\nstep_timeout_s = 60\n"
         "parallel = 2\nhello_timeout_s = " +
         std::to_string(hello_timeout_s) + "\n";
    // device "": the sim backend's default scene (deploy's default device is the camera's number).
    t += "[deploy.edge]\nstate_dir = \"\"\n[[deploy.edge.cameras]]\nbackend = "
         "\"sim\"\ndevice = \"\"\n[[deploy.edge.cameras]]\n"
         "backend = \"sim\"\ndevice = \"\"\n[deploy.edge.trigger]\nbackend = \"udp\"\n";
    put(dir / "rig.toml", t);
  }

  // Each board's trigger input: a free port of its own, kept for the test (the daemons bind it).
  int trigger_port(size_t i) {
    while (trigger_ports.size() <= i) trigger_ports.push_back(free_port());
    return trigger_ports[i];
  }
  std::vector<int> trigger_ports;

  CmdResult deploy(const std::string& args) {
    return sh(std::string(VOXCAP_BINARY) + " deploy --inventory " + (dir / "rig.toml").string() + " " + args);
  }

  fs::path etc(const std::string& id) { return dir / ("board-" + id) / "etc" / "voxcap"; }
};

std::string key_of(const fs::path& p) {
  std::string k = slurp(p);
  while (!k.empty() && k.back() == '\n') k.pop_back();
  return k;
}

TEST_F(DeploySsh, UpgradesLoopbackBoards) {
  old_board("node1");
  old_board("node2");
  rig({"node1", "node2"}, {"fake-dpkg", "fake-dpkg"});
  const CmdResult dry = deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string() + " --dry-run");
  ASSERT_EQ(dry.code, 0) << dry.out;
  EXPECT_NE(dry.out.find("[node1] runs voxcap-edge 0.0.9"), std::string::npos) << dry.out;
  EXPECT_FALSE(fs::exists(etc("node1") / "edge.toml")) << "--dry-run changed a board";

  const CmdResult r = deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("2 of 2 boards ok (voxcap-edge 0.1.0)"), std::string::npos) << r.out;
  for (const std::string id : {"node1", "node2"}) {
    SCOPED_TRACE(id);
    // Back in the rig: the real daemon's keyed HELLO on the rig's port, with the new version.
    EXPECT_NE(
        r.out.find("[" + id +
                   "] ok: voxcap-edge 0.1.0 active, proved the rig key, rejoined with 0.1.0 (HELLO, key "
                   "proved)"),
        std::string::npos)
        << r.out;
    const std::string edge = slurp(etc(id) / "edge.toml");
    EXPECT_NE(edge.find("node_id = " + id.substr(4)), std::string::npos) << edge;
    EXPECT_NE(edge.find("key = 'rig.key'"), std::string::npos) << edge;
    struct stat st {};
    ASSERT_EQ(::stat((etc(id) / "rig.key").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0600u);
    EXPECT_EQ(st.st_uid, ::getuid());
    EXPECT_EQ(key_of(etc(id) / "rig.key"), key_of(dir / "rig.key"));
    EXPECT_TRUE(fs::exists(dir / ("board-" + id) / "var/lib/voxcap/deploy/current.deb"));
    EXPECT_EQ(slurp(dir / ("board-" + id) / "installed-version"), "0.1.0-1\n");
  }
  EXPECT_NE(r.out.find("listened on the rig's port 127.0.0.1:" + std::to_string(rig_port)), std::string::npos)
      << r.out;
}

TEST_F(DeploySsh, BoardThatDoesNotRejoinIsRolledBack) {
  old_board("node1");
  old_board("node2");
  rig({"node1", "node2"}, {"fake-dpkg", "fake-dpkg"});
  ASSERT_EQ(deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string()).code, 0);
  // Again, with node2's service looking active but never joining the rig.
  put(dir / "board-node2" / "no-daemon", "");
  rig({"node1", "node2"}, {"fake-dpkg", "fake-dpkg"}, {}, 3);
  const CmdResult r = deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("[node1] ok: voxcap-edge 0.1.0 active, proved the rig key, rejoined with 0.1.0"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("[node2] FAILED: it did not rejoin the rig (no HELLO on 127.0.0.1:" +
                       std::to_string(rig_port) + " in 3 s); rolling back"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("deploy failed on: node2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[node2] rolled back: voxcap-edge 0.1.0 active again"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("node1            0.1.0      0.1.0      ok     0.1.0      ok"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("node2            0.1.0      0.1.0      ok     -          FAILED, rolled back"),
            std::string::npos)
      << r.out;
}

TEST_F(DeploySsh, FailingBoardsAreRolledBackAndNamed) {
  for (const char* id : {"node1", "node2", "node3"}) old_board(id);
  rig({"node1", "node2", "node3"}, {"fake-dpkg", "fake-dpkg", "fake-dpkg"});
  ASSERT_EQ(deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string()).code, 0);
  const std::string edge2 = slurp(etc("node2") / "edge.toml");

  // 0.2.0: node2's installer fails, node3's "succeeds" but 0.2.0 never comes up.
  // (Without the HELLO check: the stand-in 0.2.0 runs this build's daemon, whose HELLO says 0.1.0.)
  const fs::path v2 = package("0.2.0-1", "0.2.0");
  rig({"node1", "node2", "node3"}, {"fake-dpkg", "fail-dpkg", "stale-dpkg"}, {}, 0);
  const CmdResult r = deploy("--package " + v2.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("deploy failed on: node2 node3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[node1] ok: voxcap-edge 0.2.0 active"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[node2] FAILED: install failed (dpkg: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[node3] FAILED: it runs 0.1.0 after the restart, not 0.2.0"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("[node2] rolled back: voxcap-edge 0.1.0 active again"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[node3] rolled back: voxcap-edge 0.1.0 active again"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 of 3 boards ok (voxcap-edge 0.2.0)"), std::string::npos) << r.out;
  // Back as they were: the kept package and config.
  EXPECT_EQ(slurp(etc("node2") / "edge.toml"), edge2);
  EXPECT_EQ(slurp(dir / "board-node3" / "installed-version"), "0.1.0-1\n");  // previous.deb reinstalled
  EXPECT_EQ(sh(dir.string() + "/board-node3/usr/bin/voxcap-edge --version").out, "voxcap-edge 0.1.0\n");
  EXPECT_EQ(sh(dir.string() + "/board-node1/usr/bin/voxcap-edge --version").out, "voxcap-edge 0.2.0\n");
}

TEST_F(DeploySsh, RotateKeyEveryBoardProvesTheNewKey) {
  for (const char* id : {"node1", "node2", "node3"}) old_board(id);
  rig({"node1", "node2", "node3"}, {"fake-dpkg", "fake-dpkg", "fake-dpkg"});
  ASSERT_EQ(deploy("--package " + (dir / "voxcap-edge_0.1.0-1_all.deb").string()).code, 0);
  const std::string old_key = key_of(dir / "rig.key");

  CmdResult r = deploy("--rotate-key");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string new_key = key_of(dir / "rig.key");
  EXPECT_NE(new_key, old_key);
  EXPECT_EQ(key_of(dir / "rig.key.old"), old_key);
  EXPECT_FALSE(fs::exists(dir / "rig.key.next"));
  EXPECT_NE(r.out.find("rig key rotated: every board proved the new key"), std::string::npos) << r.out;
  // Every board holds both keys and proved the new one; restarted, it rejoined a host that still
  // proves the OLD key (deploy's listener holds the host's key): no capture gap.
  for (const std::string id : {"node1", "node2", "node3"}) {
    SCOPED_TRACE(id);
    EXPECT_NE(r.out.find("[" + id + "] ok: voxcap-edge 0.1.0 active, proved the NEW key"), std::string::npos)
        << r.out;
    EXPECT_NE(
        r.out.find("[" + id +
                   "] ok: voxcap-edge 0.1.0 active, proved the NEW key (and holds the old one until the "
                   "host switches), rejoined with 0.1.0 (HELLO, key proved)"),
        std::string::npos)
        << r.out;
    EXPECT_EQ(key_of(etc(id) / "rig.key"), old_key);
    EXPECT_EQ(key_of(etc(id) / "rig.key.next"), new_key);
    EXPECT_NE(slurp(etc(id) / "edge.toml").find("next_key = 'rig.key.next'"), std::string::npos);
    for (const char* f : {"rig.key", "rig.key.next"}) {
      struct stat st {};
      ASSERT_EQ(::stat((etc(id) / f).c_str(), &st), 0);
      EXPECT_EQ(st.st_mode & 0777, 0600u) << f;
    }
  }

  // The host switched: a plain deploy drops the old key from every board, and each rejoins a host
  // that proves only the new key.
  r = deploy("");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const std::string id : {"node1", "node2", "node3"}) {
    SCOPED_TRACE(id);
    EXPECT_NE(r.out.find("[" + id +
                         "] ok: voxcap-edge 0.1.0 active, proved the rig key, rejoined with 0.1.0 "
                         "(HELLO, key proved)"),
              std::string::npos)
        << r.out;
    EXPECT_EQ(key_of(etc(id) / "rig.key"), new_key);
    EXPECT_FALSE(fs::exists(etc(id) / "rig.key.next"));
    EXPECT_EQ(slurp(etc(id) / "edge.toml").find("next_key"), std::string::npos);
  }

  // Again, with node2 unable to take it (its service user does not exist: the key cannot be given to it).
  rig({"node1", "node2", "node3"}, {"fake-dpkg", "fake-dpkg", "fake-dpkg"}, {user, "no-such-user-vc", user});
  r = deploy("--rotate-key");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("boards without the new key: node2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("deploy failed on: node2"), std::string::npos) << r.out;
  EXPECT_EQ(key_of(dir / "rig.key"), new_key) << "the host switched although node2 kept the old key";
  ASSERT_TRUE(fs::exists(dir / "rig.key.next"));
  const std::string newer = key_of(dir / "rig.key.next");
  EXPECT_EQ(key_of(etc("node1") / "rig.key.next"), newer);
  EXPECT_EQ(key_of(etc("node3") / "rig.key.next"), newer);
  EXPECT_EQ(key_of(etc("node1") / "rig.key"), new_key);  // beside the key the host holds
  EXPECT_EQ(key_of(etc("node2") / "rig.key"), new_key);  // left with the key the host still holds
  EXPECT_FALSE(fs::exists(etc("node2") / "rig.key.next"));
  EXPECT_NE(r.out.find("node2            0.1.0      0.1.0      OLD"), std::string::npos) << r.out;
}

}  // namespace
