#!/usr/bin/env bash
# A host-only build needs no libcamera (CTest host_only_build, label integration): a VOXCAP_PARTS=host
# tree is configured and built on a pkg-config path that has every .pc file of this machine but
# libcamera's, as on a machine without it; no build line may name libcamera, voxcap must not link it,
# and `voxcap hil --emulated --tests alignment` must skip its cameras saying which build has them.
# Compilers, build type, warnings, sanitizers and the compiler launcher are the parent tree's; WORK_DIR
# is the host-only build tree itself (a sibling of the parent at the same depth lets ccache's base_dir
# hit on every file the two trees compile alike).
#   host_only_test.sh SOURCE_DIR PARENT_BUILD_DIR WORK_DIR [TARGET...]   (default target: voxcap)
# A single target `-` configures and checks the build lines only (what CI runs: a second tree built
# from nothing takes far longer than the suite's budget on 2 cores without a compiler cache).
set -euo pipefail
src=$(cd "$1" && pwd)
parent=$(cd "$2" && pwd)
work=$3
shift 3
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(voxcap)
fail() { echo "host_only_test: $*" >&2; exit 1; }
start=$(date +%s)

# pkg-config without libcamera.
build=$work
pc=$work/pkgconfig-without-libcamera
rm -rf "$pc"
mkdir -p "$pc"
IFS=: read -r -a dirs <<<"${PKG_CONFIG_PATH:+$PKG_CONFIG_PATH:}$(pkg-config --variable pc_path pkg-config)"
for d in "${dirs[@]}"; do
  [ -d "$d" ] || continue
  for f in "$d"/*.pc; do
    [ -e "$f" ] || continue
    case $(basename "$f") in libcamera*) continue ;; esac
    [ -e "$pc/$(basename "$f")" ] || ln -s "$f" "$pc/"
  done
done
export PKG_CONFIG_LIBDIR=$pc PKG_CONFIG_PATH=
if pkg-config --exists libcamera; then fail "libcamera still visible to pkg-config"; fi

cache() { sed -n "s/^$1:[A-Z]*=//p" "$parent/CMakeCache.txt"; }
args=(-G Ninja -DVOXCAP_PARTS=host -DVOXCAP_FUZZ=OFF
  "-DCMAKE_C_COMPILER=$(cache CMAKE_C_COMPILER)" "-DCMAKE_CXX_COMPILER=$(cache CMAKE_CXX_COMPILER)"
  "-DCMAKE_BUILD_TYPE=$(cache CMAKE_BUILD_TYPE)" "-DVOXCAP_WERROR=$(cache VOXCAP_WERROR)"
  "-DVOXCAP_SANITIZE=$(cache VOXCAP_SANITIZE)")
for v in CMAKE_C_COMPILER_LAUNCHER CMAKE_CXX_COMPILER_LAUNCHER; do
  val=$(cache $v)
  [ -z "$val" ] || args+=("-D$v=$val")
done
cmake -S "$src" -B "$build" "${args[@]}" >"$work/host_only_configure.log" 2>&1 || { tail -30 "$work/host_only_configure.log"; fail "configure"; }
if grep -qi "libcamera" "$build/build.ninja"; then
  grep -i -m3 "libcamera" "$build/build.ninja" >&2
  fail "a build line of the host-only tree names libcamera"
fi
configured=$(date +%s)
if [ "${targets[*]}" = "-" ]; then
  echo "host_only_test: VOXCAP_PARTS=host without libcamera: configured in $((configured - start)) s, no build line names libcamera (not built: -DVOXCAP_HOST_ONLY_BUILD_TEST=ON builds voxcap too)"
  exit 0
fi
cmake --build "$build" --target "${targets[@]}" >"$work/host_only_build.log" 2>&1 || { tail -40 "$work/host_only_build.log"; fail "build"; }
built=$(date +%s)

if [ -x "$build/bin/voxcap" ]; then
  if ldd "$build/bin/voxcap" | grep -q libcamera; then fail "voxcap links libcamera"; fi
  out=$("$build/bin/voxcap" hil --emulated --tests alignment 2>&1) || { echo "$out"; fail "voxcap hil --emulated"; }
  grep -q "\[alignment\] SKIPPED: .*built without the edge part" <<<"$out" || { echo "$out"; fail "no skip message"; }
fi
echo "host_only_test: VOXCAP_PARTS=host without libcamera: configured in $((configured - start)) s, built ${targets[*]} in $((built - configured)) s"
