#!/usr/bin/env bash
# The packages of a build tree (CTest packages_install, label unit): cpack makes voxcap-edge and voxcap
# (.deb, this machine's architecture); their file lists, control fields, conffiles and maintainer
# scripts are checked; both are unpacked into one scratch root (dpkg-deb -x: no maintainer script
# runs, nothing of this machine changes), and the programs run from there and find each other through
# the install layout (voxcap bench -> /usr/libexec/voxcap/voxcap-bench, voxcap rig --emulated ->
# /usr/bin/voxcap-edge, the viewer's page in /usr/share/voxcap/web).
# cpack (Ninja) installs what is built and builds nothing: the packaged programs are built first (a
# no-op after the full build CI runs before its tests).
#   package_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
work=$2
rm -rf "$work"
mkdir -p "$work"
work=$(cd "$work" && pwd)
fail() { echo "package_test: $*" >&2; exit 1; }
# has PATTERN TEXT...: grep -q over a captured text. Never `cmd | grep -q` here: under pipefail the
# writer's SIGPIPE, when grep stops at its first match, fails the pipeline.
has() { local pat=$1; shift; grep -q -- "$pat" <<<"$*"; }

start=$(date +%s)
cmake --build "$build" --target voxcap voxcap-host voxcap-edge voxcap-bench voxcap_web >"$work/build.log" 2>&1 ||
  { tail -40 "$work/build.log"; fail "the packaged programs did not build"; }
built=$(date +%s)
(cd "$build" && cpack -G DEB -B "$work/packages" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; exit 1; }
arch=$(dpkg --print-architecture)
edge=$(ls "$work"/packages/voxcap-edge_*_"$arch".deb) || fail "no voxcap-edge_*_$arch.deb"
host=$(ls "$work"/packages/voxcap_*_"$arch".deb) || fail "no voxcap_*_$arch.deb"

# Control fields and maintainer scripts.
[ "$(dpkg-deb -f "$edge" Package)" = voxcap-edge ] || fail "$edge: wrong Package"
[ "$(dpkg-deb -f "$host" Package)" = voxcap ] || fail "$host: wrong Package"
for deb in "$edge" "$host"; do
  [ "$(dpkg-deb -f "$deb" Architecture)" = "$arch" ] || fail "$deb: Architecture is not $arch"
  has adduser "$(dpkg-deb -f "$deb" Depends)" || fail "$deb: does not depend on adduser"
  has "adduser --system" "$(dpkg-deb -I "$deb" postinst)" || fail "$deb: postinst makes no service user"
done
has libcamera "$(dpkg-deb -f "$edge" Depends)" || fail "voxcap-edge does not depend on libcamera"
grep -qx /etc/voxcap/edge.toml <<<"$(dpkg-deb -I "$edge" conffiles)" || fail "edge.toml is not a conffile"

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
# Every example rig file of hw/rigs, and no third package. (A file installed without a COMPONENT is
# packed nowhere, since CPACK_COMPONENTS_ALL names edge and host: the checks by path above catch it, as
# they caught the viewer's page.)
for f in "$src"/hw/rigs/*.toml "$src"/hw/rigs/*.yaml; do
  [ -e "$f" ] && expect "$host" "/usr/share/voxcap/rigs/$(basename "$f")"
done
others=$(ls "$work"/packages/*.deb | grep -v -e "/voxcap-edge_" -e "/voxcap_" || true)
[ -z "$others" ] || fail "files installed into no package: $others"
if has "/usr/bin/voxcap-edge$" "$(dpkg-deb -c "$host")"; then fail "voxcap carries voxcap-edge"; fi
if has "voxcap-host\|voxcap-bench" "$(dpkg-deb -c "$edge")"; then fail "voxcap-edge carries host programs"; fi

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
has "Usage" "$("$root/usr/bin/voxcap" --help)" || fail "voxcap --help"
has "--config" "$("$root/usr/bin/voxcap-edge" --help)" || fail "voxcap-edge --help"
has "--config" "$("$root/usr/bin/voxcap-host" --help)" || fail "voxcap-host --help"
has "--size" "$("$root/usr/bin/voxcap" bench edge --help)" || fail "voxcap bench does not reach $root/usr/libexec/voxcap/voxcap-bench"
# voxcap rig --emulated starts voxcap-edge processes: the installed voxcap must find the installed
# voxcap-edge through the layout. The unpacked voxcap-edge is wrapped so that its runs leave a mark.
mv "$root/usr/bin/voxcap-edge" "$root/usr/bin/voxcap-edge.real"
printf '#!/bin/sh\necho "$$" >>"%s"\nexec "%s" "$@"\n' "$work/edge-ran" "$root/usr/bin/voxcap-edge.real" \
  >"$root/usr/bin/voxcap-edge"
chmod 0755 "$root/usr/bin/voxcap-edge"
rig_out=$("$root/usr/bin/voxcap" rig --emulated --nodes 1 --size 160x120 --frames 20 --no-view \
  --workdir "$work/rig" 2>&1) || { echo "$rig_out" | tail -20; fail "voxcap rig --emulated from the unpacked root"; }
[ -s "$work/edge-ran" ] || { echo "$rig_out" | tail -20; fail "voxcap did not run $root/usr/bin/voxcap-edge"; }
mv "$root/usr/bin/voxcap-edge.real" "$root/usr/bin/voxcap-edge"
done_at=$(date +%s)
echo "package_test: $(basename "$edge") $(stat -c %s "$edge") bytes, $(basename "$host") $(stat -c %s "$host") bytes: contents, units and programs checked"
echo "package_test: $((built - start)) s building the packaged programs, $((done_at - built)) s packing, unpacking and checking"
