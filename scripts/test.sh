#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds and runs
#   1. the Release build, every test (unit, integration, slow, socketcan);
#   2. the asan preset (ASan+UBSan), unit and integration tests (not slow ones);
#   3. the tsan preset (framework core and CAN library), the threading tests.
# Stops at the first failure. Usage: scripts/test.sh [ctest args...]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
jobs=$(nproc)

for preset in default asan tsan; do
  echo "=== preset $preset"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  ctest --preset "$preset" "$@"
done
