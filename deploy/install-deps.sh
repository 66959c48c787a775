#!/usr/bin/env bash
# Installs every build and test dependency of voxcap from Debian's packages: bookworm, plus
# bookworm-backports for libcamera 0.3 and libgpiod v2 (the API family current Raspberry Pi OS ships).
# Idempotent: a second run changes nothing and finishes quickly. Nothing is fetched from anywhere but
# Debian's archive. Run as root (or with sudo available).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
if [ "$codename" != "bookworm" ]; then
  echo "install-deps: this script targets Debian bookworm (found '${codename:-unknown}'); continuing anyway" >&2
fi

# bookworm-backports: libcamera-dev 0.3.x and libgpiod-dev 2.x live there.
bp=/etc/apt/sources.list.d/bookworm-backports.sources
if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  $SUDO tee "$bp" >/dev/null <<'SRC'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
fi

# Toolchain and build.
pkgs=(build-essential cmake ninja-build pkg-config git clang clang-format clang-tidy libclang-rt-14-dev lld valgrind)
# Tests and benchmarks.
pkgs+=(googletest libgtest-dev libgmock-dev libbenchmark-dev)
# Libraries of the host, the simulator and the edge.
pkgs+=(libopencv-dev libglm-dev nlohmann-json3-dev libtomlplusplus-dev libcli11-dev
       libspdlog-dev libfmt-dev libusb-1.0-0-dev libftdi1-dev linux-libc-dev)
# Rig calibration (host/calibrate): the bundle adjustment; the aruco module (opencv-contrib) for ChArUco.
pkgs+=(libceres-dev libopencv-contrib-dev)
# Authenticated control (proto/include/voxcap/auth.h): keyed BLAKE2b, crypto_kdf, randombytes.
pkgs+=(libsodium-dev)
# The live pose stream out (host/stream): VMC is OSC over UDP, built and sent with liblo.
pkgs+=(liblo-dev)
# The V4L2 VM test: a Debian kernel with the vivid module booted under qemu with a busybox initramfs.
pkgs+=(qemu-system-x86 busybox-static cpio xz-utils zstd kmod)
# The client test (label client): the exported BVH in Blender, headless, with its stock importer.
pkgs+=(blender)
# voxcap deploy's tests: an OpenSSH server on loopback stands in for a board; the flash config's
# cloud-init YAML read back with yaml-cpp.
pkgs+=(openssh-server openssh-client libyaml-cpp-dev)
# The live viewer (host/view): Boost.Beast/Asio (header-only); the browser test drives Debian's chromium
# headless through playwright-core; npm installs the page's packages (three.js) below.
pkgs+=(libboost-dev chromium)
# From bookworm-backports (pinned to that suite explicitly).
bp_pkgs=(libcamera-dev libgpiod-dev)
# The board build (deploy/cmake/toolchain-aarch64.cmake, preset arm64) and its unit tests under
# qemu-user: Debian's cross toolchain, and the edge's libraries for arm64 through multiarch, beside the
# amd64 ones. Only what can sit beside the host's packages: OpenCV's core, imgproc and video -dev and
# calib3d's runtime library (its -dev package and imgcodecs pull the arm64 GDAL, which would remove the
# host's libopencv-dev and blender; the build takes calib3d's headers from the amd64 -dev package).
pkgs+=(crossbuild-essential-arm64 qemu-user)
arm_pkgs=(libopencv-core-dev:arm64 libopencv-imgproc-dev:arm64
          libopencv-video-dev:arm64 libopencv-calib3d406:arm64 libsodium-dev:arm64 libfmt-dev:arm64
          libtomlplusplus-dev:arm64 libgtest-dev:arm64 libgmock-dev:arm64)
# libcamera-dev is not multiarch (arm64 and amd64 replace each other): its arm64 runtime library
# only; the headers are the amd64 -dev package's, the same for every architecture.
arm_bp_pkgs=(libcamera0.3:arm64 libgpiod-dev:arm64)

missing=()
for p in "${pkgs[@]}" "${bp_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# libcamera/libgpiod must be the backports versions (0.3 / 2.x), not bookworm's 0.0.3 / 1.6.
if dpkg-query -W -f='${Version}' libgpiod-dev 2>/dev/null | grep -q '^1\.'; then missing+=(libgpiod-dev); fi
if dpkg-query -W -f='${Version}' libcamera-dev 2>/dev/null | grep -q '^0\.0\.'; then missing+=(libcamera-dev); fi

arm_missing=()
for p in "${arm_pkgs[@]}" "${arm_bp_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || arm_missing+=("$p")
done
if dpkg-query -W -f='${Version}' libgpiod-dev:arm64 2>/dev/null | grep -q '^1\.'; then arm_missing+=(libgpiod-dev:arm64); fi

if [ ${#missing[@]} -gt 0 ] || [ ${#arm_missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]} ${arm_missing[*]}"
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then $SUDO dpkg --add-architecture arm64; fi
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null
  $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports "${bp_pkgs[@]}" >/dev/null
  # The arm64 libraries must never displace an amd64 package (multiarch versions must match, and some
  # arm64 packages conflict with the host's): refuse rather than remove anything.
  if apt-get install -s --no-install-recommends "${arm_pkgs[@]}" 2>&1 | grep '^Remv' >/dev/null; then
    echo "install-deps: installing the arm64 libraries would remove amd64 packages:" >&2
    apt-get install -s --no-install-recommends "${arm_pkgs[@]}" 2>&1 | grep '^Remv' >&2
    exit 1
  fi
  $SUDO apt-get install -y -qq --no-install-recommends "${arm_pkgs[@]}" >/dev/null
  if apt-get install -s --no-install-recommends -t bookworm-backports "${arm_bp_pkgs[@]}" 2>&1 | grep '^Remv' >/dev/null; then
    echo "install-deps: installing ${arm_bp_pkgs[*]} would remove amd64 packages" >&2
    exit 1
  fi
  $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports "${arm_bp_pkgs[@]}" >/dev/null
fi

# The kernel image for the VM test is unpacked into a cache folder rather than installed, so the
# machine's own /boot and /lib/modules are untouched. Debian's own package, from Debian's archive.
kcache=${VOXCAP_KERNEL_CACHE:-/var/cache/voxcap/kernel}
if [ ! -f "$kcache/ready" ]; then
  $SUDO mkdir -p "$kcache"
  tmp=$(mktemp -d); chmod 755 "$tmp"
  kpkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/{print $2; exit}')
  (cd "$tmp" && apt-get download -qq "$kpkg")
  $SUDO dpkg-deb -x "$tmp"/linux-image-*.deb "$kcache"
  rm -rf "$tmp"
  echo "$kpkg" | $SUDO tee "$kcache/ready" >/dev/null
fi
# The viewer's page and its browser test: three.js and playwright-core from the npm registry, exactly as
# host/view/web/package-lock.json pins them (nodejs/npm from Debian when the machine has no node).
command -v npm >/dev/null 2>&1 || $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
web=$(cd "$(dirname "$0")/.." && pwd)/host/view/web
if [ ! -f "$web/node_modules/.package-lock.json" ] || ! cmp -s "$web/package-lock.json" "$web/node_modules/.voxcap-lock"; then
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error) && cp "$web/package-lock.json" "$web/node_modules/.voxcap-lock"
fi
echo "install-deps: all dependencies present"
