#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# docs/writing-a-component.md, walked as a newcomer walks it, against an installed prefix: its
# code blocks are taken from the guide itself (so the guide and this walk cannot drift apart)
# and run in order: make the project (step 1), build and test it (2), put the guide's law and
# test in and build again (3), run and wire it with the guide's own commands in a naming
# service of its own, to the installed example (4), run it in one process with the installed
# example (4), run it phased and awaiting (4), and make
# and build a component of a type of its own IDL (5). Each block is checked to be the one the
# walk expects before it runs, so a guide rewritten makes this fail, not pass by running less.
#
# usage: guide_walk.sh <build folder> <guide.md>
set -uo pipefail
build=$(realpath "${1:?usage: guide_walk.sh <build folder> <guide.md>}")
guide=$(realpath "${2:?usage: guide_walk.sh <build folder> <guide.md>}")
work=$(mktemp -d)
prefix=$work/usr
fail() { echo "FAIL: $*"; exit 1; }
cleanup() {
  [[ -x $prefix/bin/rtm ]] && (cd "$work" && "$prefix/bin/rtm" names --stop >/dev/null 2>&1)
  rm -rf "$work"
}
trap cleanup EXIT

# The n-th fenced block of a language ("sh", "cpp", "idl"), without its fences.
block() {
  awk -v lang="$1" -v want="$2" '
    /^```/ { if (inside) { inside = 0; if (n == want) exit; next }
             if ($0 == "```" lang) { n++; inside = 1; next } }
    inside && n == want { print }' "$guide"
}
# expect <text> <n-th> <language> <what it must hold>
expect_block() {
  [[ $1 == *"$4"* ]] || fail "the guide's $3 block $2 no longer holds '$4': the walk must follow it: $1"
}
run() {  # run <what> <command...>: the command's output, or a failure naming the step
  local out
  out=$("${@:2}" 2>&1) || fail "$1: $out"
  printf '%s\n' "$out"
}

cmake --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 || fail "install: $(cat "$work/install.log")"
export PATH=$prefix/bin:/usr/bin:/bin XDG_RUNTIME_DIR=$work RTM_TLS= RTM_BIN_PATH=
unset RTM_NAMING
cd "$work" || exit 1

# ---- 1. rtm new component
new=$(block sh 3)
expect_block "$new" 3 sh "rtm new component gripper_ctl"
run "step 1" bash -euc "$new" >/dev/null
[[ -f gripper_ctl/src/gripper_ctl.cpp ]] || fail "step 1 made no gripper_ctl/src/gripper_ctl.cpp"

# ---- 2. build and test (the prefix is the guide's ~/rtm)
build_block=$(block sh 4)
expect_block "$build_block" 4 sh "cmake -B build"
build_block=${build_block//\~\/rtm/$prefix}
run "step 2" bash -euc "$build_block" >/dev/null

# ---- 3. the guide's law in step(), its test beside the scaffold's
law=$(block cpp 1)
test_code=$(block cpp 2)
expect_block "$law" 1 cpp "GripperCtl::Outputs GripperCtl::step("
expect_block "$test_code" 2 cpp "TEST(GripperCtl, PushingDownFiftyNewtonsClosesItHalfway)"
src=gripper_ctl/src/gripper_ctl.cpp
# The scaffold's step() (from its signature to the first line that is a lone '}') gives way to the guide's.
awk -v law="$law" '
  /^GripperCtl::Outputs GripperCtl::step\(/ { print law; skipping = 1; next }
  skipping && /^}$/ { skipping = 0; next }
  !skipping { print }' "$src" >"$src.new" && mv "$src.new" "$src"
grep -qF 'std::clamp(-0.01f * in.wrench.val[2]' "$src" || fail "step 3: the guide's law did not go into $src"
# A test of the guide's alone: the scaffold's pass-through tests no longer hold for this law.
test_file=gripper_ctl/test/gripper_ctl_test.cpp
printf '%s\n\n#include <gtest/gtest.h>\n\n%s\n' '#include "gripper_ctl/gripper_ctl.h"' "$test_code" >"$test_file"
(cd gripper_ctl && run "step 3: build" cmake --build build -j2 >/dev/null)
out=$(cd gripper_ctl && run "step 3: the guide's test" ctest --test-dir build --output-on-failure)
[[ $out == *"100% tests passed"* ]] || fail "step 3: the guide's test: $out"

# ---- 4. run it and wire it, in a naming service of its own, to the installed example
wire=$(block sh 5)
for line in 'eval "$(rtm names)"' "rtm up gripper_ctl.yaml" "rtm put gripper_ctl0.wrench 0 0 -50 0 0 0" \
            "rtm get gripper_ctl0.grip" "rtm up /usr/share/rtm/examples/source_sink/system.yaml" \
            "rtm connect source0.out0 gripper_ctl0.wrench" "rtm watch gripper_ctl0.grip" "rtm down gripper_ctl"; do
  expect_block "$wire" 5 sh "$line"
done
steps=$work/step4.sh
{
  echo "set -eu"
  while IFS= read -r line; do
    line=${line%%#*}                                        # the guide's comments
    line=${line//\/usr\/share/$prefix/share}                # the package's /usr is this prefix
    line=${line//rtm watch gripper_ctl0.grip/rtm watch gripper_ctl0.grip --count 3}  # not live: three data
    [[ $line =~ [^[:space:]] ]] || continue
    echo "echo \"+ ${line//\"/\\\"}\""
    if [[ $line == *"rtm get gripper_ctl0.grip"* ]]; then
      # The law: pushing down 50 N closes the gripper halfway, once a cycle has taken the datum in.
      echo 'for _ in $(seq 100); do got=$(rtm get gripper_ctl0.grip 2>&1) && [[ $got == *0.5000* ]] && break; sleep 0.05; done'
      echo 'echo "$got"; [[ $got == *0.5000* ]] || { echo "grip is not 0.5: $got"; exit 1; }'
    else
      echo "$line"
    fi
  done <<<"$wire"
} >"$steps"
out=$(cd gripper_ctl && bash "$steps" 2>&1) || fail "step 4: $out"
# The watch saw the ramp pushed through the law: three data of the component's grip.
[[ $(grep -c "Z  " <<<"$out") -ge 4 ]] || fail "step 4: the get and three watched data were not all shown: $out"

# ---- 4. in one process with the installed source: the guide's system file with a host
one=$(block yaml 1)
expect_block "$one" 1 yaml "host: cell0"
printf 'name: one-host\n%s\n' "$one" >gripper_ctl/one-host.yaml
out=$(cd gripper_ctl && eval "$(rtm names)" && export PATH="$prefix/bin:$PATH" RTM_BIN_PATH= RTM_MODULE_PATH= &&
      rtm up one-host.yaml 2>&1 && rtm --json cat source0 2>&1; status=$?; rtm down one-host >/dev/null 2>&1; exit $status) ||
  fail "step 4: the one-host system: $out"
[[ $out == *"(2 components in one process)"* ]] || fail "step 4: the one-host system is not one process: $out"
[[ $out == *'"in_process": true'* ]] || fail "step 4: source0 -> gripper_ctl0 is not in-process: $out"

# ---- 4. phased and awaiting, as the guide starts it (its options parse; it runs until stopped)
phased=$(block sh 7)
expect_block "$phased" 7 sh "build/bin/rtm-gripper_ctl --name gripper_ctl0 --phase 0.1ms --await wrench:0.15ms"
status=0
(cd gripper_ctl && eval "$(rtm names)" && timeout --signal=TERM 2 bash -c "$phased" >"$work/phased.log" 2>&1) || status=$?
[[ $status == 0 || $status == 124 ]] || fail "step 4: the phased run ended $status: $(cat "$work/phased.log")"
grep -q "bound gripper_ctl0" "$work/phased.log" || fail "step 4: the phased run did not bind: $(cat "$work/phased.log")"

# ---- 5. a data type of its own, made with the guide's IDL and command
idl=$(block idl 1)
expect_block "$idl" 1 idl "struct TimedPose { RTM::Time tm; Position p; double q[4]; };"
printf '%s\n' "$idl" >TimedPose.idl
typed=$(block sh 8)
expect_block "$typed" 8 sh "rtm new component tracker --in pose:My::TimedPose --out aim:My::TimedPose --idl TimedPose.idl"
run "step 5" bash -euc "$typed" >/dev/null
run "step 5: configure" cmake -S tracker -B tracker/build -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
run "step 5: build" cmake --build tracker/build -j2 >/dev/null
out=$(run "step 5: its test" ctest --test-dir tracker/build --output-on-failure)
[[ $out == *"100% tests passed"* ]] || fail "step 5: its test: $out"

echo "the guide walks as written"
