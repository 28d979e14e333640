#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Debian packages: `cpack -G DEB` in the build folder makes rtm_<version>_amd64.deb (the
# programs, examples, demo, models, docs) and rtm-dev_<version>_amd64.deb (libraries, headers,
# IDL, the CMake package), with no file in both; each depends on what it needs by Debian package
# name (rtm on omniORB's shared libraries unless the build has RTM_STATIC_OMNIORB=ON, rtm-dev on
# what building needs, the arm's libraries only recommended), states its licences in a
# machine-readable copyright file, runs from where it is unpacked, and passes lintian (when
# installed) with no tag but those its overrides state a reason for.
# usage: deb_test.sh <build folder>
set -uo pipefail
build=${1:?usage: deb_test.sh <build folder>}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

(cd "$build" && cpack -G DEB -B "$work" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; echo "FAIL: cpack"; exit 1; }
# Two packages, as Debian splits a library: the running system, and what building on it needs.
one() { local found=("$work"/"$1"_*_amd64.deb); [[ -f ${found[0]} ]] && echo "${found[0]}"; }
deb=$(one rtm) || { echo "FAIL: no rtm_*_amd64.deb in $work"; ls "$work"; exit 1; }
dev=$(one rtm-dev) || { echo "FAIL: no rtm-dev_*_amd64.deb in $work"; ls "$work"; exit 1; }
for d in "$deb" "$dev"; do
  echo "package: $(basename "$d"), $(du -k "$d" | cut -f1) kB, installed $(dpkg-deb -f "$d" Installed-Size) kB"
done

listing=$(dpkg-deb -c "$deb" | awk '{print $6}')
dev_listing=$(dpkg-deb -c "$dev" | awk '{print $6}')
for f in ./usr/bin/rtm ./usr/bin/rtm-servo ./usr/bin/rtm-controller ./usr/bin/pa10-sim ./usr/bin/rtm-example-source \
         ./usr/share/rtm/models/pa10_scene.xml ./usr/share/rtm/examples/force-servo/demo \
         ./usr/share/rtm/examples/source_sink/system.yaml ./usr/share/doc/rtm/system-files.md \
         ./usr/share/doc/rtm/copyright ./usr/share/doc/rtm/NOTICE ./usr/share/doc/rtm/changelog.gz \
         ./usr/share/bash-completion/completions/rtm ./usr/bin/rtm-container ./usr/lib/rtm/modules/rtm-controller.so; do
  grep -qxF "$f" <<<"$listing" || fail "rtm lacks $f"
done
# The core's libraries: shared (RTM_SHARED_LIBS, the default) in rtm with their link names in
# rtm-dev, or static archives in rtm-dev.
shared_libs=$(sed -n 's/^RTM_SHARED_LIBS:BOOL=//p' "$build/CMakeCache.txt")
if [[ $shared_libs =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
  core_dev=./usr/lib/librtm_core.so
  for lib in rt idl core host; do
    grep -qE "^\./usr/lib/librtm_$lib\.so\.[0-9]+\.[0-9]+\.[0-9]+$" <<<"$listing" || fail "rtm lacks librtm_$lib.so.*"
  done
  ! grep -qxF ./usr/lib/librtm_core.a <<<"$dev_listing" || fail "rtm-dev holds librtm_core.a beside the shared library"
  dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./triggers 2>/dev/null | grep -qxF 'activate-noawait ldconfig' ||
    fail "rtm has no ldconfig trigger"
else
  core_dev=./usr/lib/librtm_core.a
fi
for f in $core_dev ./usr/lib/cmake/RTM/RTMConfig.cmake ./usr/lib/cmake/RTM/RtmIdl.cmake \
         ./usr/include/rtm/host/runner.h ./usr/include/rtm/idl/RTM.hh ./usr/share/rtm/idl/RTM.idl \
         ./usr/share/rtm/scaffold/component.h.in ./usr/share/doc/rtm-dev/copyright ./usr/share/doc/rtm-dev/changelog.gz; do
  grep -qxF "$f" <<<"$dev_listing" || fail "rtm-dev lacks $f"
done
# dpkg installs both only when no file is in both.
both=$(comm -12 <(grep -v '/$' <<<"$listing" | sort) <(grep -v '/$' <<<"$dev_listing" | sort))
[[ -z $both ]] || fail "files in both packages: $(tr '\n' ' ' <<<"$both")"
for d in "$deb" "$dev"; do
  description=$(dpkg-deb -f "$d" Description)
  [[ $description == *"RT-Middleware component framework"* ]] || fail "$(basename "$d"): Description: $description"
  ! grep -q ';' <<<"$description" || fail "Description holds a CMake list separator: $description"
done
depends=$(dpkg-deb -f "$deb" Depends)
for p in omniorb-nameserver libmujoco libssl3; do
  [[ $depends == *"$p"* ]] || fail "rtm's Depends lacks $p: $depends"
done
python=$(sed -n 's/^RTM_WITH_PYTHON:BOOL=//p' "$build/CMakeCache.txt")
if [[ $python =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
  grep -qxF ./usr/lib/python3/dist-packages/rtm/__init__.py <<<"$listing" || fail "rtm lacks the Python package"
  grep -qE '^\./usr/lib/python3/dist-packages/rtm/_rtm\.cpython-[0-9]+-x86_64-linux-gnu\.so$' <<<"$listing" ||
    fail "rtm lacks the Python module rtm._rtm"
  [[ $depends == *python3-numpy* ]] || fail "rtm's Depends lacks python3-numpy (import rtm): $depends"
  for file in rtm/motion.py rtm/script.py; do
    grep -qxF "./usr/lib/python3/dist-packages/$file" <<<"$listing" || fail "rtm lacks the Python package's $file"
  done
  grep -qxF ./usr/share/rtm/examples/force-servo/slide.py <<<"$listing" || fail "rtm lacks the motion script example"
fi
for p in libomniorb4-dev liborocos-kdl-dev cmake; do
  [[ $depends != *"$p"* ]] || fail "rtm depends on $p, which only building needs: $depends"
done
dev_depends=$(dpkg-deb -f "$dev" Depends)
version=$(dpkg-deb -f "$deb" Version)
for p in "rtm (= $version)" omniidl libomniorb4-dev libspdlog-dev cmake; do
  [[ $dev_depends == *"$p"* ]] || fail "rtm-dev's Depends lacks $p: $dev_depends"
done
[[ $dev_depends != *liborocos-kdl-dev* ]] || fail "rtm-dev depends on KDL, which only the PA10's part needs: $dev_depends"
[[ $(dpkg-deb -f "$dev" Recommends) == *liborocos-kdl-dev* ]] || fail "rtm-dev does not recommend KDL for the PA10's part"
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
dpkg-deb -x "$deb" "$work/root" || fail "dpkg-deb -x rtm"
dpkg-deb -x "$dev" "$work/root" || fail "dpkg-deb -x rtm-dev"
"$work/root/usr/bin/rtm" --help >"$work/help" 2>&1 || fail "rtm --help: $(cat "$work/help")"
"$work/root/usr/bin/pa10-sim" --help >"$work/help" 2>&1 || fail "pa10-sim --help"
if [[ $python =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
  # The unpacked module finds the unpacked libraries beside it, and Debian's omniORB and numpy.
  PYTHONPATH="$work/root/usr/lib/python3/dist-packages" /usr/bin/python3 -c \
    'import rtm, sys; sys.exit(0 if rtm.System and rtm.Component else 1)' >"$work/python" 2>&1 ||
    fail "import rtm from the unpacked package: $(cat "$work/python")"
  # rtm script finds the package beside itself (<prefix>/lib/python3/dist-packages).
  "$work/root/usr/bin/rtm" script --help-script >"$work/script" 2>&1 ||
    fail "rtm script --help-script from the unpacked package: $(cat "$work/script")"
  grep -q "^usage: rtm script" "$work/script" || fail "rtm script --help-script: $(cat "$work/script")"
fi
grep -qF "$work/root/usr/share/rtm/models/pa10_scene.xml" "$work/help" || fail "pa10-sim does not look beside itself"
# What rtm needs, itself or through RTM's shared libraries.
needed=$(for f in "$work/root/usr/bin/rtm" "$work"/root/usr/lib/librtm_*.so.*.*.*; do
  [[ -f $f ]] && objdump -p "$f" | awk '$1 == "NEEDED" {print $2}'
done | sort -u)
for so in libomniORB4.so.2 libomniDynamic4.so.2 libomnisslTP4.so.2 libomnithread.so.4; do
  if [[ $static_omniorb =~ ^(ON|TRUE|YES|Y|1)$ ]]; then
    ! grep -qxF "$so" <<<"$needed" || fail "rtm links $so, though omniORB is linked statically"
  else
    grep -qxF "$so" <<<"$needed" || fail "rtm does not link $so: $(tr '\n' ' ' <<<"$needed")"
  fi
done

# The copyright file is machine-readable (DEP-5) and states RTM's licence.
for copyright in "$work"/root/usr/share/doc/rtm/copyright "$work"/root/usr/share/doc/rtm-dev/copyright; do
  head -1 "$copyright" | grep -qxF 'Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' ||
    fail "$copyright is not in Debian's machine-readable format"
  grep -qxF 'License: Apache-2.0' "$copyright" || fail "$copyright does not state Apache-2.0"
done

if command -v lintian >/dev/null; then
  lintian --tag-display-limit 0 "$deb" "$dev" 2>&1 | grep -E '^[EWI]:' >"$work/lintian"
  if [[ -s $work/lintian ]]; then fail "lintian: $(cat "$work/lintian")"; else echo "lintian: clean"; fi
else
  echo "lintian: not installed, not run"
fi
((fails)) && { echo "$fails failed"; exit 1; }
echo "the package is as it should be"
