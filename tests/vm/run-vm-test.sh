#!/usr/bin/env bash
# Boots Debian's kernel under qemu (TCG) with a busybox initramfs that loads vivid and runs the static
# V4L2 test program; parses its VCVM lines. Used by CTest (label vm); runnable by hand:
#   tests/vm/run-vm-test.sh --program build/ci/bin/vc_v4l2_vmtest --workdir /tmp/vm [--timeout 240]
# Needs the kernel cache that deploy/install-deps.sh unpacks (VOXCAP_KERNEL_CACHE, default
# /var/cache/voxcap/kernel), busybox-static, cpio and qemu-system-x86. Never skips: a missing piece fails.
set -euo pipefail

program="" workdir="" timeout_s=240 frames=60 fps=60 size=320x180
while [ $# -gt 0 ]; do
  case "$1" in
    --program) program=$2; shift 2 ;;
    --workdir) workdir=$2; shift 2 ;;
    --timeout) timeout_s=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --fps) fps=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    *) echo "run-vm-test: unknown argument $1" >&2; exit 2 ;;
  esac
done
fail() { echo "run-vm-test: FAIL: $*" >&2; exit 1; }
[ -n "$program" ] && [ -x "$program" ] || fail "test program '$program' missing (build target vc_v4l2_vmtest)"
[ -n "$workdir" ] || fail "--workdir not given"

kcache=${VOXCAP_KERNEL_CACHE:-/var/cache/voxcap/kernel}
vmlinuz=$(ls "$kcache"/boot/vmlinuz-* 2>/dev/null | head -n1 || true)
[ -n "$vmlinuz" ] || fail "no kernel in $kcache/boot: run deploy/install-deps.sh (it unpacks linux-image-amd64 there)"
kver=${vmlinuz##*/vmlinuz-}
moddir=$kcache/lib/modules/$kver/kernel/drivers/media
[ -d "$moddir" ] || fail "no media modules in $moddir: run deploy/install-deps.sh"
busybox=$(command -v busybox || true)
[ -n "$busybox" ] || fail "busybox not found: run deploy/install-deps.sh (busybox-static)"
if readelf -l "$busybox" 2>/dev/null | grep -q INTERP; then
  fail "$busybox is dynamically linked: install busybox-static (deploy/install-deps.sh)"
fi
command -v cpio >/dev/null || fail "cpio not found: run deploy/install-deps.sh"
qemu=$(command -v qemu-system-x86_64 || true)
[ -n "$qemu" ] || fail "qemu-system-x86_64 not found: run deploy/install-deps.sh"
if readelf -l "$program" 2>/dev/null | grep -q INTERP; then fail "$program is not static"; fi

# The load order the issue fixes (each module after what it depends on).
modules=(
  mc/mc.ko v4l2-core/videodev.ko rc/rc-core.ko cec/core/cec.ko v4l2-core/v4l2-dv-timings.ko
  common/v4l2-tpg/v4l2-tpg.ko common/videobuf2/videobuf2-common.ko common/videobuf2/videobuf2-memops.ko
  common/videobuf2/videobuf2-vmalloc.ko common/videobuf2/videobuf2-dma-contig.ko
  common/videobuf2/videobuf2-v4l2.ko test-drivers/vivid/vivid.ko
)

root=$workdir/initramfs
rm -rf "$root"
mkdir -p "$root"/bin "$root"/dev "$root"/proc "$root"/sys "$root"/modules
cp "$busybox" "$root"/bin/busybox
cp "$program" "$root"/bin/vmtest
names=()
for m in "${modules[@]}"; do
  [ -f "$moddir/$m" ] || fail "module $moddir/$m missing: run deploy/install-deps.sh"
  cp "$moddir/$m" "$root/modules/"
  b=${m##*/}; names+=("${b%.ko}")
done

cat > "$root/init" <<EOF
#!/bin/busybox sh
/bin/busybox mount -t devtmpfs devtmpfs /dev
/bin/busybox mount -t proc proc /proc
/bin/busybox mount -t sysfs sysfs /sys
for m in ${names[*]}; do
  args=""
  # one instance, a single-planar video capture node only (no fb/vbi/radio/sdr/meta/touch nodes)
  [ "\$m" = vivid ] && args="n_devs=1 node_types=0x1 multiplanar=1"
  /bin/busybox insmod /modules/\$m.ko \$args || echo "VCVM-INSMOD-FAIL \$m"
done
i=0
while [ ! -e /dev/video0 ] && [ \$i -lt 50 ]; do /bin/busybox usleep 100000; i=\$((i+1)); done
/bin/vmtest --device /dev/video0 --frames $frames --fps $fps --size $size
echo "VCVM-EXIT rc=\$?"
/bin/busybox poweroff -f
EOF
chmod 755 "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet) > "$workdir/initramfs.cpio"

log=$workdir/console.log
echo "run-vm-test: booting $vmlinuz (timeout ${timeout_s}s), console log in $log"
start=$(date +%s)
set +e
timeout --kill-after=10 "$timeout_s" "$qemu" -accel tcg -m 512 -smp 1 -nographic -no-reboot \
  -kernel "$vmlinuz" -initrd "$workdir/initramfs.cpio" \
  -append "console=ttyS0 panic=-1 quiet" </dev/null >"$log" 2>&1
qrc=$?
set -e
end=$(date +%s)
tr -d '\r' < "$log" > "$log.txt"
grep -E '^VCVM' "$log.txt" || true
echo "run-vm-test: qemu exited $qrc after $((end - start)) s"
[ $qrc -ne 124 ] && [ $qrc -ne 137 ] || { tail -n 40 "$log.txt" >&2; fail "VM timed out after ${timeout_s}s"; }
if grep -q '^VCVM-INSMOD-FAIL' "$log.txt"; then tail -n 60 "$log.txt" >&2; fail "a module failed to load"; fi
summary=$(grep -E '^VCVM-SUMMARY ' "$log.txt" | tail -n1 || true)
[ -n "$summary" ] || { tail -n 60 "$log.txt" >&2; fail "no VCVM-SUMMARY line: the test program did not finish"; }
pass=$(sed -E 's/.*pass=([0-9]+).*/\1/' <<<"$summary")
nfail=$(sed -E 's/.*fail=([0-9]+).*/\1/' <<<"$summary")
# every format must have streamed; every check must pass
for f in rgb24 yuyv grey; do
  grep -qE "^VCVM check=stream_$f result=PASS " "$log.txt" || fail "format $f did not stream"
done
[ "$nfail" -eq 0 ] || fail "$nfail check(s) failed"
[ "$pass" -ge 15 ] || fail "only $pass checks ran"
echo "run-vm-test: PASS ($pass checks)"
