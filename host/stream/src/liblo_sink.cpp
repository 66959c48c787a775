// The real VMC sink: each bundle built with liblo (OSC 1.0, Debian's liblo) and sent over UDP from a
// liblo server socket of our own, made non-blocking, so a send never waits: a full socket buffer is an
// error the stage counts. Nothing is ever read from that socket (the receiver does not answer).
#include <fcntl.h>
#include <lo/lo.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "voxcap/stream/vmc_sink.hpp"

namespace vc::stream {
namespace {

void quiet(int, const char*, const char*) {}  // failures are reported by the calls' results

void add_transform(lo_message m, const VmcTransform& t) {
  lo_message_add_float(m, static_cast<float>(t.p.x));
  lo_message_add_float(m, static_cast<float>(t.p.y));
  lo_message_add_float(m, static_cast<float>(t.p.z));
  lo_message_add_float(m, static_cast<float>(t.q.x));
  lo_message_add_float(m, static_cast<float>(t.q.y));
  lo_message_add_float(m, static_cast<float>(t.q.z));
  lo_message_add_float(m, static_cast<float>(t.q.w));
}

class LibloSink : public VmcSink {
 public:
  explicit LibloSink(const config::Endpoint& target) : target_(target.str()) {
    // The socket is IPv4 (liblo's default for a server): send "localhost" to IPv4's loopback, not ::1.
    const std::string host = target.host == "localhost" ? "127.0.0.1" : target.host;
    server_ = lo_server_new_with_proto(nullptr, LO_UDP, quiet);
    if (!server_) throw std::runtime_error("vmc: liblo could not open a UDP socket");
    const int fd = lo_server_get_socket_fd(server_);
    const int flags = fd >= 0 ? fcntl(fd, F_GETFL) : -1;
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) {
      lo_server_free(server_);
      throw std::runtime_error(
          fmt::format("vmc: cannot make the UDP socket non-blocking: {}", std::strerror(errno)));
    }
    address_ = lo_address_new(host.c_str(), std::to_string(target.port).c_str());
    if (!address_) {
      lo_server_free(server_);
      throw std::runtime_error(fmt::format("vmc: liblo cannot address {}", target_));
    }
  }
  ~LibloSink() override {
    lo_address_free(address_);
    lo_server_free(server_);
  }
  LibloSink(const LibloSink&) = delete;
  LibloSink& operator=(const LibloSink&) = delete;

  bool send(const VmcPacket& p, std::string* why) override {
    lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
    if (!b) return fail(why, "out of memory");
    bool built = true;
    auto add = [&](const char* path, lo_message m) {
      if (!m || lo_bundle_add_message(b, path, m) != 0) {
        if (m) lo_message_free(m);
        built = false;
      }
    };
    if (p.has_pose) {
      lo_message root = lo_message_new();
      if (root) {
        lo_message_add_string(root, "root");
        add_transform(root, p.pose.root);
      }
      add("/VMC/Ext/Root/Pos", root);
      for (int k = 0; k < kVmcBoneCount; ++k) {
        lo_message m = lo_message_new();
        if (m) {
          lo_message_add_string(m, std::string(vmc_bone_name(k)).c_str());
          add_transform(m, p.pose.bones[static_cast<size_t>(k)]);
        }
        add("/VMC/Ext/Bone/Pos", m);
      }
    }
    lo_message ok = lo_message_new();
    if (ok) {
      lo_message_add_int32(ok, p.loaded);
      lo_message_add_int32(ok, p.calibration_state);
      lo_message_add_int32(ok, p.calibration_mode);
      lo_message_add_int32(ok, p.tracking);
    }
    add("/VMC/Ext/OK", ok);
    lo_message t = lo_message_new();
    if (t) lo_message_add_float(t, static_cast<float>(p.time_s));
    add("/VMC/Ext/T", t);
    const int sent = built ? lo_send_bundle_from(address_, server_, b) : -1;
    lo_bundle_free_recursive(b);
    if (!built) return fail(why, "out of memory building the bundle");
    if (sent < 0) {
      const char* s = lo_address_errstr(address_);
      return fail(why, s && *s ? s : fmt::format("error {}", lo_address_errno(address_)));
    }
    return true;
  }

  std::string target() const override { return target_; }

 private:
  static bool fail(std::string* why, std::string m) {
    if (why) *why = std::move(m);
    return false;
  }
  std::string target_;
  lo_server server_ = nullptr;
  lo_address address_ = nullptr;
};

}  // namespace

std::unique_ptr<VmcSink> make_liblo_sink(const config::Endpoint& target) {
  return std::make_unique<LibloSink>(target);
}

}  // namespace vc::stream
