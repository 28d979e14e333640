#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
#
# Installs the MCAP reference reader harness into BUILD_DIR/mcap-reference/:
# copies package.json, package-lock.json and read.mjs there and runs `npm ci`
# when the lock file differs from the one last installed. node_modules is
# only ever created under BUILD_DIR, never in the source tree.
#
# Usage: setup.sh BUILD_DIR
# Then:  node BUILD_DIR/mcap-reference/read.mjs FILE [--stream] [--raw] [--start NS] [--end NS]
set -euo pipefail

die() {
    echo "mcap-reference setup: $*" >&2
    exit 1
}

[[ $# -eq 1 && -n "$1" ]] || die "usage: setup.sh BUILD_DIR"

src_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
mkdir -p "$1" || die "cannot create $1"
build_dir=$(cd "$1" && pwd)
dest="$build_dir/mcap-reference"
[[ "$dest" != "$src_dir" ]] || die "BUILD_DIR must not be the source folder"

command -v node >/dev/null 2>&1 || die "node (Node.js >= 18) not found in PATH; install nodejs"
command -v npm >/dev/null 2>&1 || die "npm not found in PATH; install npm"
node_major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null) ||
    die "cannot run node"
((node_major >= 18)) || die "Node.js >= 18 needed, found $(node --version)"

mkdir -p "$dest"

# Copy a file only when it changed, so the folder stays untouched otherwise.
copy_if_changed() {
    if ! cmp -s "$src_dir/$1" "$dest/$1"; then
        cp "$src_dir/$1" "$dest/$1.tmp" && mv -f "$dest/$1.tmp" "$dest/$1"
    fi
}
copy_if_changed package.json
copy_if_changed package-lock.json
copy_if_changed read.mjs

stamp="$dest/.installed-package-lock.json"
if [[ -d "$dest/node_modules" ]] && cmp -s "$dest/package-lock.json" "$stamp"; then
    exit 0
fi

rm -f "$stamp"
log="$dest/npm-ci.log"
if ! (cd "$dest" && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error) >"$log" 2>&1; then
    cat "$log" >&2
    die "npm ci failed in $dest (log: $log)"
fi
cp "$dest/package-lock.json" "$stamp"
rm -f "$log"
