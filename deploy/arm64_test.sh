#!/usr/bin/env bash
# The board build in CI (CTest arm64_cross, labels unit;arm64): configures an arm64 tree of the edge
# part (deploy/cmake/toolchain-aarch64.cmake, VOXCAP_PARTS=edge: proto, hw/rig, edge), builds it,
# runs the kernels' and the protocol's unit tests under qemu-aarch64 (among them
# the NEON kernels against the portable C, bit for bit), and voxcap-edge --help and --version.
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
# Only the kernels' and the protocol's test programs: the part CI checks under emulation (the whole edge
# tree builds with `cmake --build --preset arm64`; its other tests are not run here, see deploy/README.md).
cmake --build "$build" -j "$jobs" --target edge_core_test proto_unit_test voxcap-edge >"$work/build.log" 2>&1 ||
  { tail -n 60 "$work/build.log"; exit 1; }
t1=$(date +%s)
# -L /: the multiarch libc6:arm64 and its own loader (toolchain-aarch64.cmake says why not the cross
# toolchain's). SIGKILL on timeout: qemu-user hands SIGTERM to the guest, which may not die of it.
qemu=(qemu-aarch64 -L /)
for t in edge/core/tests/edge_core_test proto/proto_unit_test; do
  log=$work/$(basename "$t").log
  timeout -s KILL 1500 "${qemu[@]}" "$build/$t" --gtest_brief=1 >"$log" 2>&1 || { tail -n 40 "$log"; echo "arm64_test: $t failed under qemu" >&2; exit 1; }
  tail -n 3 "$log"
done
# The NEON kernels ran (not skipped): the bit-exact comparisons against the portable C, every one
# that started passed (none skipped), and there are some.
timeout -s KILL 600 "${qemu[@]}" "$build/edge/core/tests/edge_core_test" --gtest_filter='Kernels/KernelVariant.*/neon:EdgeKernels.*' \
  >"$work/neon.log" 2>&1 || { cat "$work/neon.log"; exit 1; }
neon_run=$(grep -c 'RUN      \] Kernels/KernelVariant\..*/neon' "$work/neon.log" || true)
neon_ok=$(grep -c 'OK \] Kernels/KernelVariant\..*/neon' "$work/neon.log" || true)
[ "$neon_run" -ge 3 ] && [ "$neon_ok" = "$neon_run" ] &&
  grep -q 'OK \] EdgeKernels.RleEncodeEqualsPortableByteForByte' "$work/neon.log" ||
  { cat "$work/neon.log"; echo "arm64_test: the NEON comparisons did not all run and pass" >&2; exit 1; }
# The daemon starts under emulation (libcamera, lttng-ust, OpenCV and the rest load): --help and
# --version answer and exit 0.
edge=$build/bin/voxcap-edge
timeout -s KILL 120 "${qemu[@]}" "$edge" --help >"$work/edge_help.log" 2>&1 &&
  grep -q -- '--config' "$work/edge_help.log" ||
  { cat "$work/edge_help.log"; echo "arm64_test: voxcap-edge --help failed under qemu" >&2; exit 1; }
version=$(timeout -s KILL 120 "${qemu[@]}" "$edge" --version 2>&1) &&
  [[ "$version" =~ ^voxcap-edge\ [0-9]+\.[0-9]+\.[0-9]+$ ]] ||
  { echo "$version"; echo "arm64_test: voxcap-edge --version failed under qemu" >&2; exit 1; }
echo "arm64_test: $version: --help and --version under qemu"
t2=$(date +%s)
echo "arm64_test: configure+build $((t1 - t0)) s, tests under qemu $((t2 - t1)) s: NEON kernels equal the portable C bit for bit"
