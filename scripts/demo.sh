#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The README's first command: the paper's force servo on the simulated PA10.
#   1. installs missing Debian packages (scripts/deps.sh) and builds the default preset;
#   2. runs examples/force-servo/demo: a private omniNames on a free loopback port, pa10-sim
#      in real time playing the operator profile on a fresh local bus, the five components
#      (rtm up), live values, then a summary, a CSV and a PNG plot in an output folder.
# Every option goes to the demo (--help lists them), e.g. --out DIR, or --bus socketcan:can0
# to drive the real arm. Idempotent: a second run installs nothing and rebuilds only what
# changed; no fixed ports or paths; everything started is stopped on exit, Ctrl-C included.
# RTM_DEMO_BUILD_DIR=<dir> uses that (configured) build tree instead of the default preset's.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/deps.sh
build_dir=${RTM_DEMO_BUILD_DIR:-build/default}
[[ -n "${RTM_DEMO_BUILD_DIR:-}" ]] || cmake --preset default >/dev/null
cmake --build "$build_dir" -j"$(nproc)" --target rtm pa10-sim rtm-sensor rtm-joystick rtm-controller \
  rtm-actuator rtm-servo rtm-demo-report
exec examples/force-servo/demo --bin "$(cd "$build_dir/bin" && pwd)" "$@"
