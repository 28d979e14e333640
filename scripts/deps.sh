#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the Debian 12 packages RTM needs: only those missing. Idempotent.
#   scripts/deps.sh        what building and running the demo needs
#   scripts/deps.sh test   that, and what the test suite needs besides (QEMU and busybox for the
#                          SocketCAN tests' guest, can-utils and kmod)
# Runs apt-get as root (directly, or through sudo when not root). Installs no kernel: the
# SocketCAN tests' guest kernel is fetched into a cache by scripts/vm-vcan-run, never installed.
set -euo pipefail

packages=(
  g++ cmake make pkg-config git
  libomniorb4-dev omniidl omniorb-nameserver libssl-dev
  libeigen3-dev liborocos-kdl-dev liburdfdom-dev
  libmujoco-dev libqhull-dev
  libcli11-dev libyaml-cpp-dev libfmt-dev libspdlog-dev nlohmann-json3-dev libcpp-httplib-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  liblz4-dev libzstd-dev zlib1g-dev
  gnuplot-nox procps iproute2 ccache
  python3-dev pybind11-dev python3-numpy
)
case "${1:-}" in
  "") ;;
  test)
    packages+=(qemu-system-x86 busybox-static kmod xz-utils util-linux can-utils dpkg-dev lintian chromium chromium-driver python3-selenium nodejs python3-pytest)
    # npm for the MCAP reference readers (tests/mcap/reference); a Node.js from elsewhere
    # that brings its own npm is kept.
    command -v npm >/dev/null || packages+=(npm) ;;
  *) echo "usage: $0 [test]" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "deps: all ${#packages[@]} packages present"
  exit 0
fi

as_root=()
if ((EUID != 0)); then
  command -v sudo >/dev/null || { echo "deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  as_root=(sudo)
fi
echo "deps: installing ${missing[*]}"
"${as_root[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
