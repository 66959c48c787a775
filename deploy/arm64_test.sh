#!/usr/bin/env bash
# The board build in CI (CTest arm64_cross, labels unit;arm64): configures an arm64 tree of the edge
# part (deploy/cmake/toolchain-aarch64.cmake, VOXCAP_PARTS=edge: proto, hw/rig, edge), builds it,
# runs its unit tests under qemu-aarch64 (CTest, through CMAKE_CROSSCOMPILING_EMULATOR: among them
# the NEON kernels against the portable C, bit for bit), makes the voxcap-edge arm64 package and runs
# `voxcap-edge --help` from it unpacked into a scratch root.
#   arm64_test.sh SOURCE_DIR WORK_DIR [JOBS]
# Exit 77 (skipped) without the cross toolchain or qemu-user, except under CI=true, where that fails.
set -euo pipefail
src=$(cd "$1" && pwd)
work=$2
jobs=${3:-2}
for tool in aarch64-linux-gnu-g++ qemu-aarch64 dpkg-deb; do
  if ! command -v "$tool" >/dev/null; then
    if [ "${CI:-}" = "true" ]; then
      echo "arm64_test: $tool missing (deploy/install-deps.sh installs it)" >&2
      exit 1
    fi
    echo "arm64_test: skipped: $tool missing (deploy/install-deps.sh installs it)"
    exit 77
  fi
done
mkdir -p "$work"
build=$work/build
t0=$(date +%s)
# The same cache as the arm64 preset (CMakePresets.json), into this test's own folder.
cmake -S "$src" -B "$build" -G Ninja --toolchain "$src/deploy/cmake/toolchain-aarch64.cmake" \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOXCAP_PARTS=edge -DVOXCAP_WERROR=OFF >"$work/configure.log" 2>&1 ||
  { cat "$work/configure.log"; exit 1; }
cmake --build "$build" -j "$jobs" >"$work/build.log" 2>&1 || { tail -n 60 "$work/build.log"; exit 1; }
t1=$(date +%s)
ctest --test-dir "$build" -L unit -j "$jobs" --output-on-failure --timeout 900 | tee "$work/ctest.log" | tail -n 15
t2=$(date +%s)
grep -q "100% tests passed" "$work/ctest.log" || { echo "arm64_test: unit tests failed under qemu" >&2; exit 1; }
# The NEON kernels ran (not skipped): the bit-exact comparisons are in the log.
grep -Eq "Kernels/KernelVariant\.(Subtract|Carve)EqualsGenericBitForBit/neon .*Passed" "$work/ctest.log" ||
  ctest --test-dir "$build" -R 'KernelVariant.*neon' -V 2>&1 | grep -q "OK \]" ||
  { echo "arm64_test: the NEON kernel comparisons did not run" >&2; exit 1; }

# The voxcap-edge arm64 package, unpacked and run.
(cd "$build" && cpack -G DEB >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; exit 1; }
deb=$(ls "$build"/packages/voxcap-edge_*_arm64.deb)
test "$(dpkg-deb -f "$deb" Package)" = voxcap-edge
test "$(dpkg-deb -f "$deb" Architecture)" = arm64
root=$work/root
rm -rf "$root"
dpkg-deb -x "$deb" "$root"
for f in usr/bin/voxcap-edge etc/voxcap/edge.toml usr/lib/systemd/system/voxcap-edge.service; do
  test -e "$root/$f" || { echo "arm64_test: $f missing from $deb" >&2; exit 1; }
done
file_out=$(file -b "$root/usr/bin/voxcap-edge" 2>/dev/null || echo "")
case "$file_out" in *aarch64*|"") ;; *) echo "arm64_test: voxcap-edge is not an aarch64 program: $file_out" >&2; exit 1 ;; esac
qemu-aarch64 -L /usr/aarch64-linux-gnu "$root/usr/bin/voxcap-edge" --help | grep -q -- "--config"
t3=$(date +%s)
echo "arm64_test: configure+build $((t1 - t0)) s, unit tests under qemu $((t2 - t1)) s, package $((t3 - t2)) s"
echo "arm64_test: $deb ($(stat -c %s "$deb") bytes) installs and runs under qemu-aarch64"
