// rig.toml's deploy keys ([deploy], [[nodes]] ssh and [nodes.deploy]) and the boards' edge.toml.
#include "voxcap/deploy/inventory.hpp"

#include <fmt/core.h>

#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "config.hpp"  // voxcap-edge's own edge.toml reader (edge/daemon)
#include "voxcap/rig/input_file.hpp"

namespace vc::deploy {
namespace {

struct Reader {
  std::string file;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw InventoryError(fmt::format("{}: {}: {}", file, key, what));
  }
  void check_keys(const toml::table& t, const std::string& prefix, const std::set<std::string>& known) const {
    for (const auto& [k, v] : t) {
      const std::string key(k.str());
      if (!known.count(key)) {
        std::string list;
        for (const auto& c : known) list += (list.empty() ? "" : ", ") + c;
        fail(prefix + key, "unknown key; takes: " + list);
      }
    }
  }
  bool str(const toml::table& t, const std::string& prefix, const char* key, std::string& out) const {
    const toml::node* n = t.get(key);
    if (!n) return false;
    if (!n->is_string()) fail(prefix + key, "expected a string");
    out = **n->as_string();
    for (char c : out)
      if (c == '\n' || c == '\r' || c == '\0') fail(prefix + key, "must be one line");
    return true;
  }
  bool integer(const toml::table& t, const std::string& prefix, const char* key, int& out, int lo,
               int hi) const {
    const toml::node* n = t.get(key);
    if (!n) return false;
    if (!n->is_integer()) fail(prefix + key, "expected an integer");
    const int64_t v = **n->as_integer();
    if (v < lo || v > hi) fail(prefix + key, fmt::format("must be in [{}, {}], got {}", lo, hi, v));
    out = static_cast<int>(v);
    return true;
  }
  bool number(const toml::table& t, const std::string& prefix, const char* key, double& out, double lo,
              double hi) const {
    const toml::node* n = t.get(key);
    if (!n) return false;
    if (n->is_integer())
      out = static_cast<double>(**n->as_integer());
    else if (n->is_floating_point())
      out = **n->as_floating_point();
    else
      fail(prefix + key, "expected a number");
    if (!(out >= lo && out <= hi))
      fail(prefix + key, fmt::format("must be in [{}, {}], got {}", lo, hi, out));
    return true;
  }
};

const std::set<std::string> kBoardKeys = {"ssh_user",
                                          "ssh_port",
                                          "identity",
                                          "known_hosts",
                                          "host_key_checking",
                                          "connect_timeout_s",
                                          "step_timeout_s",
                                          "sudo",
                                          "dpkg",
                                          "systemctl",
                                          "root",
                                          "service_user",
                                          "service",
                                          "settle_s",
                                          "edge"};
const std::set<std::string> kGlobalKeys = {
    "host_address",   "parallel", "package", "admin_user", "authorized_key", "package_repo",
    "network_prefix", "gateway",  "dns",     "timezone",   "hello_timeout_s"};

std::filesystem::path relative_to(const std::filesystem::path& base, const std::string& p) {
  std::filesystem::path out(p);
  if (out.is_relative()) out = base / out;
  return std::filesystem::absolute(out).lexically_normal();
}

// The keys one board may have in [deploy] or [nodes.deploy].
void read_board(const Reader& r, const toml::table& t, const std::string& prefix,
                const std::filesystem::path& dir, BoardSettings& b) {
  std::string s;
  r.str(t, prefix, "ssh_user", b.ssh_user);
  r.integer(t, prefix, "ssh_port", b.ssh_port, 1, 65535);
  if (r.str(t, prefix, "identity", s)) b.identity = relative_to(dir, s);
  if (r.str(t, prefix, "known_hosts", s)) b.known_hosts = relative_to(dir, s);
  r.str(t, prefix, "host_key_checking", b.host_key_checking);
  r.integer(t, prefix, "connect_timeout_s", b.connect_timeout_s, 1, 600);
  r.integer(t, prefix, "step_timeout_s", b.step_timeout_s, 5, 7200);
  r.str(t, prefix, "sudo", b.sudo);
  r.str(t, prefix, "dpkg", b.dpkg);
  r.str(t, prefix, "systemctl", b.systemctl);
  r.str(t, prefix, "root", b.root);
  r.str(t, prefix, "service_user", b.service_user);
  r.str(t, prefix, "service", b.service);
  r.number(t, prefix, "settle_s", b.settle_s, 0, 600);
  if (const toml::node* e = t.get("edge"); e && !e->is_table()) r.fail(prefix + "edge", "expected a table");
  std::string why;
  if (!b.valid(&why)) r.fail(prefix + why.substr(0, why.find(':')), why.substr(why.find(':') + 2));
}

// Inline tables ({ a = 1 }) printed as sections, so the text parses again as a document.
void deinline(toml::table& t) {
  t.is_inline(false);
  for (auto&& [k, v] : t) {
    if (v.is_table()) deinline(*v.as_table());
    if (v.is_array())
      for (auto& e : *v.as_array())
        if (e.is_table()) deinline(*e.as_table());
  }
}

std::string table_text(const toml::table* t) {
  if (!t) return "";
  toml::table copy = *t;
  deinline(copy);
  std::ostringstream os;
  os << copy;
  return os.str();
}

// Copies `from` into `to`, tables merged key by key, arrays of tables element by element.
void merge(toml::table& to, const toml::table& from) {
  for (const auto& [k, v] : from) {
    toml::node* have = to.get(k);
    if (have && have->is_table() && v.is_table()) {
      merge(*have->as_table(), *v.as_table());
    } else if (have && have->is_array_of_tables() && v.is_array_of_tables()) {
      toml::array& a = *have->as_array();
      const toml::array& b = *v.as_array();
      for (size_t i = 0; i < b.size(); ++i) {
        if (i < a.size())
          merge(*a.get(i)->as_table(), *b.get(i)->as_table());
        else
          a.push_back(*b.get(i)->as_table());
      }
    } else {
      to.insert_or_assign(k, v);
    }
  }
}

template <typename T>
void set_default(toml::table& t, const char* key, T value) {
  if (!t.contains(key)) t.insert(key, value);
}

}  // namespace

bool BoardSettings::valid(std::string* why) const {
  auto bad = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (host_key_checking != "yes" && host_key_checking != "accept-new")
    return bad(
        fmt::format("host_key_checking: must be \"yes\" or \"accept-new\", got \"{}\"", host_key_checking));
  if (service.empty() || service.find_first_of(" ;&|$`'\"\\") != std::string::npos)
    return bad("service: must be one unit name");
  if (service_user.empty() || service_user.find_first_of(" ;&|$`'\"\\/:") != std::string::npos)
    return bad("service_user: must be one user name");
  if (!root.empty() && (root.front() != '/' || root.find_first_of(" ;&|$`'\"\\") != std::string::npos))
    return bad("root: must be an absolute path without spaces or shell characters");
  if (dpkg.empty()) return bad("dpkg: must not be empty");
  if (systemctl.empty()) return bad("systemctl: must not be empty");
  return true;
}

const Board* Inventory::board(const std::string& id) const {
  for (const Board& b : boards)
    if (b.id == id) return &b;
  return nullptr;
}

std::string check_edge_toml(const std::string& text, const std::string& name) {
  try {
    edge::EdgeSettings s;
    edge::parse_edge_toml(text, name, s);
    s.validate();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string make_edge_toml(const config::RigConfig& rig, size_t node_index, const std::string& host_address,
                           const std::string& edge_template_toml, const std::string& node_edge_toml) {
  const config::NodeConfig& node = rig.nodes.at(node_index);
  toml::table t;
  try {
    t = toml::parse(edge_template_toml);
    merge(t, toml::parse(node_edge_toml));
  } catch (const toml::parse_error& e) {
    throw InventoryError(fmt::format("{}: deploy.edge: {}", rig.source.string(), e.description()));
  }
  t.insert_or_assign("node_id",
                     static_cast<int64_t>(config::node_number(node, node_index, rig.source.string())));
  if (!rig.key_path.empty())
    t.insert_or_assign("key", "rig.key");  // beside edge.toml: /etc/voxcap/rig.key
  else
    t.erase("key");
  set_default(t, "state_dir", std::string("/var/lib/voxcap"));
  if (!t.contains("host")) t.insert("host", toml::table{});
  toml::table& host = *t.get("host")->as_table();
  host.insert_or_assign("address", host_address);
  host.insert_or_assign("port", static_cast<int64_t>(rig.network.port));

  if (!t.contains("cameras")) t.insert("cameras", toml::array{});
  if (!t.get("cameras")->is_array())
    throw InventoryError(rig.source.string() + ": deploy.edge.cameras: expected [[cameras]] tables");
  toml::array& cams = *t.get("cameras")->as_array();
  while (cams.size() < 2) cams.push_back(toml::table{});
  for (size_t k = 0; k < 2; ++k) {
    if (!cams.get(k)->is_table())
      throw InventoryError(rig.source.string() + ": deploy.edge.cameras: expected [[cameras]] tables");
    toml::table& c = *cams.get(k)->as_table();
    const int index = rig.camera_index(node.cameras.at(k));
    c.insert_or_assign("index", static_cast<int64_t>(index));
    set_default(c, "backend", std::string("libcamera"));
    set_default(c, "device", std::to_string(k));
    set_default(c, "external_trigger", true);
    if (index >= 0 && static_cast<size_t>(index) < rig.calibration.cameras.size()) {
      const auto& cal = rig.calibration.cameras[static_cast<size_t>(index)];
      set_default(c, "width", static_cast<int64_t>(cal.width));
      set_default(c, "height", static_cast<int64_t>(cal.height));
    }
  }
  if (!t.contains("trigger")) t.insert("trigger", toml::table{});
  toml::table& trig = *t.get("trigger")->as_table();
  set_default(trig, "backend", std::string("gpiod"));
  trig.insert_or_assign("active_low", rig.trigger.active_low);  // the edge stamps the host's leading edge

  std::ostringstream os;
  os << "# edge.toml of node " << node.id << " (node_id " << *t.get("node_id")->value<int64_t>()
     << ") of rig " << rig.name << ", written by voxcap deploy from " << rig.source.filename().string()
     << ".\n# Keys: edge/daemon/README.md. Change the rig file and deploy again rather than this file.\n"
     << t << "\n";
  std::string text = os.str();
  const std::string why = check_edge_toml(text, node.id + "/edge.toml");
  if (!why.empty())
    throw InventoryError(fmt::format("{}: the edge.toml made for node {} is refused by voxcap-edge: {}",
                                     rig.source.string(), node.id, why));
  return text;
}

Inventory load_inventory(const std::filesystem::path& rig_toml) {
  Inventory inv;
  inv.rig = config::load_rig_config(rig_toml);
  const std::string file = rig_toml.string();
  const std::filesystem::path dir = std::filesystem::absolute(rig_toml).parent_path();
  toml::table top;
  try {
    top = toml::parse(rig::read_input_file(file, config::kMaxRigTomlBytes), file);
  } catch (const std::exception& e) {
    throw InventoryError(fmt::format("{}: {}", file, e.what()));
  }
  const Reader r{file};
  BoardSettings base;
  const toml::table empty;
  const toml::table* dep = top.get("deploy") ? top.get("deploy")->as_table() : nullptr;
  if (top.get("deploy") && !dep) r.fail("deploy", "expected a table");
  if (!dep) dep = &empty;
  std::set<std::string> known = kBoardKeys;
  known.insert(kGlobalKeys.begin(), kGlobalKeys.end());
  r.check_keys(*dep, "deploy.", known);
  read_board(r, *dep, "deploy.", dir, base);
  std::string s;
  r.integer(*dep, "deploy.", "parallel", inv.parallel, 1, 64);
  r.integer(*dep, "deploy.", "hello_timeout_s", inv.hello_timeout_s, 0, 600);
  if (r.str(*dep, "deploy.", "package", s)) inv.package = relative_to(dir, s);
  if (!r.str(*dep, "deploy.", "host_address", inv.host_address)) {
    const std::string& listen = inv.rig.network.listen;
    if (listen.empty() || listen == "any" || listen == "0.0.0.0")
      inv.host_address = "";  // checked below, only if a board needs it
    else
      inv.host_address = listen;
  }
  r.str(*dep, "deploy.", "admin_user", inv.flash.admin_user);
  if (r.str(*dep, "deploy.", "authorized_key", s)) inv.flash.authorized_key = relative_to(dir, s);
  r.str(*dep, "deploy.", "package_repo", inv.flash.package_repo);
  r.integer(*dep, "deploy.", "network_prefix", inv.flash.network_prefix, 1, 32);
  r.str(*dep, "deploy.", "gateway", inv.flash.gateway);
  r.str(*dep, "deploy.", "timezone", inv.flash.timezone);
  if (const toml::node* d = dep->get("dns")) {
    if (!d->is_array()) r.fail("deploy.dns", "expected an array of addresses");
    for (const auto& e : *d->as_array()) {
      if (!e.is_string()) r.fail("deploy.dns", "expected an array of addresses");
      inv.flash.dns.push_back(**e.as_string());
    }
  }
  if (inv.flash.admin_user.empty())
    inv.flash.admin_user = base.ssh_user.empty() ? "voxcap-admin" : base.ssh_user;
  if (inv.host_address.empty())
    r.fail("deploy.host_address",
           "missing: network.listen is \"any\", so name the address the boards reach the host at");
  const std::string edge_template = table_text(dep->get("edge") ? dep->get("edge")->as_table() : nullptr);

  const toml::array* nodes = top.get("nodes") ? top.get("nodes")->as_array() : nullptr;
  for (size_t i = 0; i < inv.rig.nodes.size(); ++i) {
    const config::NodeConfig& node = inv.rig.nodes[i];
    const toml::table& nt = *nodes->get(i)->as_table();
    const std::string prefix = fmt::format("nodes[{}].", i);
    Board b;
    b.id = node.id;
    b.number = config::node_number(node, i, file);
    b.address = node.address;
    b.settings = base;
    const toml::table* nd = nullptr;
    if (const toml::node* n = nt.get("deploy")) {
      if (!n->is_table()) r.fail(prefix + "deploy", "expected a table");
      nd = n->as_table();
      r.check_keys(*nd, prefix + "deploy.", kBoardKeys);
      read_board(r, *nd, prefix + "deploy.", dir, b.settings);
    }
    if (!r.str(nt, prefix, "ssh", b.settings.ssh)) {
      if (node.address.empty() || node.address == "any")
        r.fail(prefix + "ssh", "missing: the node's address is \"any\", so name its ssh target (user@host)");
      b.settings.ssh = (b.settings.ssh_user.empty() ? "" : b.settings.ssh_user + "@") + node.address;
    }
    if (b.settings.ssh.empty() || b.settings.ssh.front() == '-' ||
        b.settings.ssh.find_first_of(" ;&|$`'\"\\") != std::string::npos)
      r.fail(prefix + "ssh", fmt::format("not an ssh target: \"{}\"", b.settings.ssh));
    b.edge_toml = make_edge_toml(inv.rig, i, inv.host_address, edge_template,
                                 table_text(nd && nd->get("edge") ? nd->get("edge")->as_table() : nullptr));
    inv.boards.push_back(std::move(b));
  }
  return inv;
}

}  // namespace vc::deploy
