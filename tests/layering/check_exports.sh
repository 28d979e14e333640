#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Each library exports only include folders of its own: folders inside the folder that builds
# it (its include/), or generated ones in the build tree; never the project root, which would
# let its users include any header of the tree.
# usage: check_exports.sh PROJECT_SOURCE_DIR PROJECT_BINARY_DIR EXPORTS_FILE
#   EXPORTS_FILE: one line per library, "target|source folder|folder,folder,..." (written by
#   the top CMakeLists.txt). Prints each violation; exits 1 if there is any.
set -uo pipefail
root=${1:?usage}
build=${2:?usage}
exports=${3:?usage}
[[ -s $exports ]] || { echo "no libraries listed in $exports"; exit 2; }
violations=0 libraries=0
inside() { [[ $1 == "$2" || $1 == "$2"/* ]]; }
while IFS='|' read -r target source dirs; do
  [[ -n $target ]] || continue
  libraries=$((libraries + 1))
  IFS=',' read -ra list <<<"$dirs"
  for dir in "${list[@]}"; do
    [[ -n $dir ]] || continue
    dir=${dir%/}
    if [[ $dir == "$root" ]]; then
      echo "$target exports the project root $dir: export its own include folder"
    elif inside "$dir" "$build"; then
      continue  # generated headers (IDL stubs, configured files)
    elif ! inside "$dir" "$source"; then
      echo "$target (built in ${source#"$root"/}) exports ${dir#"$root"/}, a folder not its own"
    else
      continue
    fi
    violations=$((violations + 1))
  done
done <"$exports"
if ((violations)); then
  echo "$violations export violation(s)"
  exit 1
fi
echo "exports: each of $libraries libraries exports only its own include folders"
