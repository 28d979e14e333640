#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The bash completion script: parses, and completes commands and options.
# usage: completion_test.sh <rtm-completion.bash>
set -u
script=$1
bash -n "$script" || { echo "FAIL: $script does not parse"; exit 1; }
# shellcheck disable=SC1090
source "$script"
fails=0
expect() {  # expect "<words>" "<expected completions>"
  local -a words
  read -r -a words <<<"$1"
  [[ $1 == *" " ]] && words+=("")
  COMP_WORDS=("${words[@]}")
  COMP_CWORD=$((${#words[@]} - 1))
  COMPREPLY=()
  _rtm
  local got="${COMPREPLY[*]}"
  if [[ "$got" != "$2" ]]; then
    echo "FAIL: '$1' completed to '$got', expected '$2'"
    fails=$((fails + 1))
  else
    echo "ok: '$1' -> '$got'"
  fi
}
expect "rtm c" "cat connect check"
expect "rtm s" "set serve script"
expect "rtm d" "disconnect down demo"
expect "rtm r" "reset record replay"
expect "rtm replay rtm-controller x.mcap --s" "--set --show"
expect "rtm p" "put play"
expect "rtm record --c" "--compression --count"
expect "rtm play x.mcap --l" "--loop"
expect "rtm --js" "--json"
expect "rtm ls -" "-l --long --clean --names"
expect "rtm --naming 127.0.0.1:2809 w" "watch"
expect "rtm watch --r" "--rate"
expect "rtm connect --o" "--once"
expect "rtm connect --p" "--policy"
expect "rtm t" "tls"
expect "rtm na" "names"
expect "rtm up x.yaml --s" "--set"
expect "rtm up x.yaml --f" "--force"
expect "rtm put t.in0 1 --r" "--rate"
expect "rtm names --s" "--stop"
expect "rtm new c" "component"
expect "rtm new component x --o" "--out"
expect "rtm new component x --de" "--description"
expect "rtm new component x --t" "--types"
expect "rtm new component x --py" "--python"
expect "rtm demo --no" "--no-realtime"
expect "rtm script --help-" "--help-script"
expect "rtm script slide.py --p" "--pose"
expect "rtm script slide.py --name s0 --r" "--reference"
expect "rtm tls i" "init issue"
expect "rtm --tls /nonexistent-folder g" "get"
# Component names come from `rtm ls --names`: here a function stands in for a running system.
rtm() { [[ $* == "ls --names" ]] && printf '%s\n' actuator0 alpha; }
expect "rtm ls a" "actuator0 alpha"
expect "rtm ls al" "alpha"
expect "rtm cat ac" "actuator0"
unset -f rtm
if ((fails)); then echo "$fails failed"; exit 1; fi
echo "all completions as expected"
