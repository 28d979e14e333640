#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Debian package: `cpack -G DEB` in the build folder makes rtm_<version>_amd64.deb that
# holds the programs, libraries, headers, IDL, models and the CMake package, depends on what
# they need by Debian package name (omniORB's shared libraries unless the build has
# RTM_STATIC_OMNIORB=ON), states its licences in a machine-readable copyright file, runs from
# where it is unpacked, and passes lintian (when installed) with no tag but those its
# overrides state a reason for.
# usage: deb_test.sh <build folder>
set -uo pipefail
build=${1:?usage: deb_test.sh <build folder>}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

(cd "$build" && cpack -G DEB -B "$work" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; echo "FAIL: cpack"; exit 1; }
debs=("$work"/rtm_*_amd64.deb)
[[ -f ${debs[0]} ]] || { echo "FAIL: no rtm_*_amd64.deb in $work"; ls "$work"; exit 1; }
deb=${debs[0]}
echo "package: $(basename "$deb"), $(du -k "$deb" | cut -f1) kB, installed $(dpkg-deb -f "$deb" Installed-Size) kB"

listing=$(dpkg-deb -c "$deb" | awk '{print $6}')
for f in ./usr/bin/rtm ./usr/bin/rtm-servo ./usr/bin/rtm-controller ./usr/bin/pa10-sim ./usr/lib/librtm_core.a \
         ./usr/lib/cmake/RTM/RTMConfig.cmake ./usr/lib/cmake/RTM/RtmIdl.cmake ./usr/include/rtm/host/runner.h \
         ./usr/include/rtm/idl/RTM.hh ./usr/share/rtm/idl/RTM.idl ./usr/share/rtm/models/pa10_scene.xml \
         ./usr/share/doc/rtm/copyright ./usr/share/doc/rtm/NOTICE ./usr/share/doc/rtm/changelog.gz \
         ./usr/share/bash-completion/completions/rtm; do
  grep -qxF "$f" <<<"$listing" || fail "the package lacks $f"
done
description=$(dpkg-deb -f "$deb" Description)
[[ $description == *"a PA10 force servo"* ]] || fail "Description lacks its text: $description"
! grep -q ';' <<<"$description" || fail "Description holds a CMake list separator: $description"
depends=$(dpkg-deb -f "$deb" Depends)
for p in omniorb-nameserver omniidl libomniorb4-dev libmujoco libssl3 liburdfdom cmake; do
  [[ $depends == *"$p"* ]] || fail "Depends lacks $p: $depends"
done
# omniORB: Debian's shared libraries, or (RTM_STATIC_OMNIORB=ON) its archives linked in.
static_omniorb=$(sed -n 's/^RTM_STATIC_OMNIORB:BOOL=//p' "$build/CMakeCache.txt")
if [[ $static_omniorb =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
  echo "omniORB: linked statically (RTM_STATIC_OMNIORB=$static_omniorb)"
else
  echo "omniORB: Debian's shared libraries"
  for p in libomniorb4-2 libomnithread4; do
    [[ $depends =~ (^|, )$p( |,|$) ]] || fail "Depends lacks $p: $depends"
  done
fi

# Unpacked anywhere, the programs run and pa10-sim finds its scene beside itself.
dpkg-deb -x "$deb" "$work/root" || fail "dpkg-deb -x"
"$work/root/usr/bin/rtm" --help >"$work/help" 2>&1 || fail "rtm --help: $(cat "$work/help")"
"$work/root/usr/bin/pa10-sim" --help >"$work/help" 2>&1 || fail "pa10-sim --help"
grep -qF "$work/root/usr/share/rtm/models/pa10_scene.xml" "$work/help" || fail "pa10-sim does not look beside itself"
needed=$(objdump -p "$work/root/usr/bin/rtm" | awk '$1 == "NEEDED" {print $2}')
for so in libomniORB4.so.2 libomniDynamic4.so.2 libomnisslTP4.so.2 libomnithread.so.4; do
  if [[ $static_omniorb =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
    ! grep -qxF "$so" <<<"$needed" || fail "usr/bin/rtm links $so, though omniORB is linked statically"
  else
    grep -qxF "$so" <<<"$needed" || fail "usr/bin/rtm does not link $so: $(tr '\n' ' ' <<<"$needed")"
  fi
done

# The copyright file is machine-readable (DEP-5) and states RTM's licence.
copyright=$work/root/usr/share/doc/rtm/copyright
head -1 "$copyright" | grep -qxF 'Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' ||
  fail "copyright is not in Debian's machine-readable format"
grep -qxF 'License: Apache-2.0' "$copyright" || fail "copyright does not state Apache-2.0"

if command -v lintian >/dev/null; then
  lintian --tag-display-limit 0 "$deb" 2>&1 | grep -E '^[EWI]:' >"$work/lintian"
  if [[ -s $work/lintian ]]; then fail "lintian: $(cat "$work/lintian")"; else echo "lintian: clean"; fi
else
  echo "lintian: not installed, not run"
fi
((fails)) && { echo "$fails failed"; exit 1; }
echo "the package is as it should be"
