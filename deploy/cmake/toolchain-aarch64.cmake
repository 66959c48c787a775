# Cross-compiling voxcap for a 64-bit ARM board (Raspberry Pi 5, Raspberry Pi OS bookworm arm64) on a
# Debian bookworm amd64 machine, with Debian's cross toolchain (crossbuild-essential-arm64) and the
# arm64 -dev packages installed beside the amd64 ones through multiarch (dpkg --add-architecture arm64;
# deploy/install-deps.sh does both). Headers are shared (/usr/include), libraries live in
# /usr/lib/aarch64-linux-gnu, so the "sysroot" is the machine itself: no copied board image.
#
#   cmake --preset arm64          (CMakePresets.json: this file, VOXCAP_PARTS=edge)
#   ctest --preset arm64          (the unit tests under qemu-aarch64, see CMAKE_CROSSCOMPILING_EMULATOR)
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(VC_TRIPLET aarch64-linux-gnu)

set(CMAKE_C_COMPILER ${VC_TRIPLET}-gcc)
set(CMAKE_CXX_COMPILER ${VC_TRIPLET}-g++)
# Debian's multiarch layout: find_library / find_package look in /usr/lib/aarch64-linux-gnu.
set(CMAKE_LIBRARY_ARCHITECTURE ${VC_TRIPLET})
# Programs (protoc-like generators, pkg-config) run on the build machine; libraries, headers and
# CMake package files come from the arm64 packages only, never from the amd64 ones.
set(CMAKE_FIND_ROOT_PATH /usr/${VC_TRIPLET})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# pkg-config answers for arm64: its .pc files only (the amd64 ones would name x86-64 libraries).
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/${VC_TRIPLET}/pkgconfig:/usr/share/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "")

# Test programs run under qemu-user (Debian qemu-user) with the arm64 dynamic loader and libraries of
# the multiarch tree: -L / (qemu resolves the ELF interpreter /lib/ld-linux-aarch64.so.1 under that
# prefix; Debian's libc6:arm64 puts it there). Not -L /usr/aarch64-linux-gnu: that prefix holds the
# cross toolchain's own glibc (libc6-arm64-cross, 2.36-8cross1), whose ld.so then runs the multiarch
# libc.so.6 (libc6:arm64, 2.36-9+deb12u14), a pair built apart; programs that pull in lttng-ust
# (libcamera: voxcap-edge) spun inside that ld.so in lttng-ust's constructor, before main.
find_program(VC_QEMU_AARCH64 NAMES qemu-aarch64 qemu-aarch64-static)
if(VC_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${VC_QEMU_AARCH64} -L /)
endif()

# The Pi 5's Cortex-A76 is ARMv8.2-A; the packages target plain ARMv8-A (every 64-bit Pi): NEON
# (Advanced SIMD) is part of the baseline, so no -m flag is needed for the NEON kernels.
