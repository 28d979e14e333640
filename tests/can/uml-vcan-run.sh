#!/bin/bash
# Runs a command inside User-Mode Linux, where the kernel has SocketCAN and vcan0 is up.
#
# For hosts whose kernel has no CAN stack (socket(AF_CAN) -> EAFNOSUPPORT): Debian's
# user-mode-linux boots a Linux kernel as an ordinary process in a few seconds. The guest's root
# is the host's filesystem (hostfs, read-only), so COMMAND runs unchanged, from the host's
# current directory. The host's /tmp is mounted writable at /tmp in the guest (so a checkout or
# build under /tmp works, and sockets made there are seen by both). Timing inside UML is not
# real-time:
# use it for function, never for latency figures.
#
# usage: uml-vcan-run.sh [-m MEM] [-t SECONDS] [-i IFNAME]... -- COMMAND [ARGS...]
#   -m MEM      guest memory (default 512M)
#   -t SECONDS  kill the guest after this long (default 240); exit code 124 then
#   -i IFNAME   vcan interface to create and bring up (default vcan0; repeatable)
# Prints COMMAND's output (stdout and stderr together) and exits with COMMAND's exit code.
# Exit code 125: the guest could not run the command (UML, a module or the boot failed; the
# reason is printed on stderr). Environment variables named RTM_*, GTEST_*, ASAN_OPTIONS,
# UBSAN_OPTIONS, LSAN_OPTIONS and TSAN_OPTIONS are passed into the guest.
#
# Needs the Debian packages user-mode-linux (the 'linux' binary and its modules under
# /usr/lib/uml/modules), kmod (insmod) and iproute2 (ip); can-utils when COMMAND uses candump.
set -euo pipefail

mem=512M
timeout_s=240
interfaces=()
usage() { echo "usage: $0 [-m MEM] [-t SECONDS] [-i IFNAME]... -- COMMAND [ARGS...]" >&2; exit 2; }
while (($#)); do
  case "$1" in
    -m) (($# >= 2)) || usage; mem=$2; shift 2 ;;
    -t) (($# >= 2)) || usage; timeout_s=$2; shift 2 ;;
    -i) (($# >= 2)) || usage; interfaces+=("$2"); shift 2 ;;
    --) shift; break ;;
    *) usage ;;
  esac
done
(($#)) || usage
((${#interfaces[@]})) || interfaces=(vcan0)

missing() { echo "uml-vcan-run: $1" >&2; exit 125; }

uml=${UML_LINUX:-$(command -v linux || true)}
[[ -n "$uml" && -x "$uml" ]] ||
  missing "no User-Mode Linux kernel ('linux' not on PATH): install Debian's user-mode-linux"
for tool in insmod ip; do
  for dir in /usr/sbin /sbin /usr/bin /bin; do [[ -x "$dir/$tool" ]] && continue 2; done
  missing "'$tool' not found (packages kmod and iproute2)"
done

# The guest kernel's version names its module directory; there is one per installed UML.
module_root=
for dir in /usr/lib/uml/modules/*/kernel; do
  [[ -d "$dir" ]] && module_root=$dir
done
[[ -n "$module_root" ]] || missing "no UML modules under /usr/lib/uml/modules (user-mode-linux incomplete)"
modules=(net/can/can net/can/can-raw drivers/net/can/dev/can-dev drivers/net/can/vcan)
for m in "${modules[@]}"; do
  [[ -f "$module_root/$m.ko" ]] || missing "UML module $module_root/$m.ko is missing"
done

out=$(mktemp -d "${TMPDIR:-/tmp}/uml-vcan.XXXXXX")
chmod 755 "$out"
cleanup() { rm -rf "$out"; }
trap cleanup EXIT

{
  echo '#!/bin/sh'
  echo 'export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin'
  echo 'mount -t proc proc /proc && mount -t sysfs sysfs /sys'
  echo 'mount -t tmpfs tmpfs /run && mount -t tmpfs tmpfs /dev/shm 2>/dev/null'
  printf 'mkdir -p /run/out && mount -t hostfs -o %q hostfs /run/out || { poweroff -f; }\n' "$out"
  echo 'fail() { echo "$1" >/run/out/guest-error; sync; poweroff -f; }'
  echo 'mount -t hostfs -o /tmp hostfs /tmp || mount -t tmpfs tmpfs /tmp || fail "cannot mount /tmp"'
  echo 'M=/usr/lib/uml/modules/$(uname -r)/kernel'
  echo '[ -d "$M" ] || fail "no modules for the guest kernel $(uname -r) in /usr/lib/uml/modules"'
  for m in "${modules[@]}"; do
    printf 'insmod "$M/%s.ko" 2>>/run/out/guest-error || fail "insmod %s failed"\n' "$m" "$m"
  done
  for ifname in "${interfaces[@]}"; do
    printf 'ip link add dev %q type vcan && ip link set up %q || fail "cannot create %q"\n' \
      "$ifname" "$ifname" "$ifname"
  done
  echo 'ip link set up lo'
  # Pass the variables tests and sanitizers read.
  while IFS='=' read -r name _; do
    case "$name" in
      RTM_* | GTEST_* | ASAN_OPTIONS | UBSAN_OPTIONS | LSAN_OPTIONS | TSAN_OPTIONS)
        printf 'export %s=%q\n' "$name" "${!name}" ;;
    esac
  done < <(env)
  printf 'cd %q || fail "cannot enter %q in the guest"\n' "$PWD" "$PWD"
  printf '%q ' "$@"
  echo '>/run/out/log 2>&1 </dev/null'
  echo 'echo $? >/run/out/rc'
  echo 'sync'
  echo 'poweroff -f'
} >"$out/init"
chmod 755 "$out/init"

# UML itself always exits 0; the command's exit code comes back through the rc file.
status=0
timeout -k 10 "$timeout_s" "$uml" mem="$mem" root=/dev/root rootfstype=hostfs rootflags=/ ro quiet \
  init="$out/init" con0=fd:0,fd:1 con=null </dev/null >"$out/console" 2>&1 || status=$?
[[ -f "$out/log" ]] && cat "$out/log"
if [[ -f "$out/rc" ]]; then
  exit "$(cat "$out/rc")"
fi
if ((status == 124)); then
  echo "uml-vcan-run: the guest did not finish within ${timeout_s} s (killed)" >&2
  exit 124
fi
if [[ -s "$out/guest-error" ]]; then
  echo "uml-vcan-run: $(tail -n 3 "$out/guest-error")" >&2
else
  echo "uml-vcan-run: the guest did not run the command; last console lines:" >&2
  tail -n 20 "$out/console" >&2
fi
exit 125
