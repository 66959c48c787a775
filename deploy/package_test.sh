#!/usr/bin/env bash
# The packages of a build tree (CTest packages_install, label unit): cpack makes voxcap-edge and voxcap
# (.deb, this machine's architecture); their file lists, control fields, conffiles and maintainer
# scripts are checked; both are unpacked into one scratch root (dpkg-deb -x: no maintainer script
# runs, nothing of this machine changes), and the programs run from there and find each other through
# the install layout (voxcap bench -> /usr/libexec/voxcap/voxcap-bench).
#   package_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
work=$2
rm -rf "$work"
mkdir -p "$work"
fail() { echo "package_test: $*" >&2; exit 1; }

(cd "$build" && cpack -G DEB -B "$work/packages" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; exit 1; }
arch=$(dpkg --print-architecture)
edge=$(ls "$work"/packages/voxcap-edge_*_"$arch".deb) || fail "no voxcap-edge_*_$arch.deb"
host=$(ls "$work"/packages/voxcap_*_"$arch".deb) || fail "no voxcap_*_$arch.deb"

# Control fields and maintainer scripts.
[ "$(dpkg-deb -f "$edge" Package)" = voxcap-edge ] || fail "$edge: wrong Package"
[ "$(dpkg-deb -f "$host" Package)" = voxcap ] || fail "$host: wrong Package"
for deb in "$edge" "$host"; do
  [ "$(dpkg-deb -f "$deb" Architecture)" = "$arch" ] || fail "$deb: Architecture is not $arch"
  dpkg-deb -f "$deb" Depends | grep -q adduser || fail "$deb: does not depend on adduser"
  dpkg-deb -I "$deb" postinst | grep -q "adduser --system" || fail "$deb: postinst makes no service user"
done
dpkg-deb -f "$edge" Depends | grep -q libcamera || fail "voxcap-edge does not depend on libcamera"
dpkg-deb -I "$edge" conffiles | grep -qx /etc/voxcap/edge.toml || fail "edge.toml is not a conffile"

# File lists.
expect() { # deb, paths...
  local deb=$1; shift
  local list; list=$(dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|')
  for p in "$@"; do grep -qx "$p" <<<"$list" || fail "$(basename "$deb") lacks $p"; done
}
expect "$edge" /usr/bin/voxcap-edge /etc/voxcap/edge.toml /usr/lib/systemd/system/voxcap-edge.service \
  /usr/share/voxcap/examples/edge.toml
expect "$host" /usr/bin/voxcap /usr/bin/voxcap-host /usr/libexec/voxcap/voxcap-bench \
  /usr/lib/systemd/system/voxcap-host.service /usr/lib/udev/rules.d/60-voxcap.rules \
  /usr/share/voxcap/rigs/pi5-gpiod.toml /usr/share/voxcap/rigs/emulated.toml \
  /usr/share/voxcap/web/index.html /usr/share/voxcap/web/app.js /usr/share/voxcap/web/protocol.js \
  /usr/share/voxcap/web/style.css
if dpkg-deb -c "$edge" | grep -q "voxcap-host\|voxcap-bench"; then fail "voxcap-edge carries host programs"; fi

# The units: the keys the service relies on.
unit=$(dpkg-deb --fsys-tarfile "$edge" | tar -xO ./usr/lib/systemd/system/voxcap-edge.service)
for key in "Restart=on-failure" "CPUSchedulingPolicy=fifo" "LimitRTPRIO=" "User=voxcap" \
  "SupplementaryGroups=video gpio" "ExecStart=/usr/bin/voxcap-edge --config /etc/voxcap/edge.toml"; do
  grep -q "^$key" <<<"$unit" || fail "voxcap-edge.service lacks $key"
done
unit=$(dpkg-deb --fsys-tarfile "$host" | tar -xO ./usr/lib/systemd/system/voxcap-host.service)
for key in "Restart=on-failure" "LimitRTPRIO=" "User=voxcap" "ExecStart=/usr/bin/voxcap-host --config /etc/voxcap/rig.toml"; do
  grep -q "^$key" <<<"$unit" || fail "voxcap-host.service lacks $key"
done

# Unpacked into a scratch root: the programs run, and find each other there.
root=$work/root
dpkg-deb -x "$edge" "$root"
dpkg-deb -x "$host" "$root"
"$root/usr/bin/voxcap" --help | grep -q "Usage" || fail "voxcap --help"
"$root/usr/bin/voxcap-edge" --help | grep -q -- "--config" || fail "voxcap-edge --help"
"$root/usr/bin/voxcap-host" --help | grep -q -- "--config" || fail "voxcap-host --help"
"$root/usr/bin/voxcap" bench edge --help | grep -q -- "--size" || fail "voxcap bench does not reach $root/usr/libexec/voxcap/voxcap-bench"
echo "package_test: $(basename "$edge") $(stat -c %s "$edge") bytes, $(basename "$host") $(stat -c %s "$host") bytes: contents, units and programs checked"
