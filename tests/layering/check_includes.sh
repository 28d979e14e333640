#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The project's layering, checked on its #include lines (see docs/architecture.md):
#   src/         the framework core: no robot code (arm/, sim/, components/), no tools/, and
#                nothing of host/ (it keeps hooks that host/ fills)
#   host/        the runner, composites, access screen, TLS and leases: no robot code, no
#                tools/
#   src/rt/      the real-time base under everything: no CORBA (nor the core), no robot code
#   src/mcap/    the MCAP file format: no CORBA (nor the core), no real-time base, no robot code
#   arm/         the arm and CAN library: no CORBA (omniORB, the IDL stubs, the core rtm/),
#                no simulator, no component
#   sim/         the simulator: no CORBA, no component
#   tools/       no robot code; its rooms, each a library, call only downwards:
#                browser/ (find, describe, connect, values): no launcher, server or scaffold,
#                  no HTTP, and it prints nothing (its results are values and JSON)
#                launcher/ (system files, rtm up/down): the browser only
#                recorder/ (rtm record): the browser and the launcher, not the server or scaffold
#                serve/ (rtm serve): the browser, the launcher and the recorder, not the scaffold
#                scaffold/ (rtm new): writes files, asks nothing of a running system
#                rtm/ (the command line) is on no other room's include path
#   python/      the Python package (rtm._rtm over the browser and the launcher): no robot code
#   components/  included only by components (a composite's executable makes its members)
#                and tests;
#                a component's logic (all but its main.cpp) stands on the core: no host/
#   bench/       tests' code only through tests/support's libraries (rtm_test/...)
# usage: check_includes.sh SOURCE_DIR   prints each violation as file:line: rule: the #include;
#        exits 1 if there is any
set -uo pipefail
root=${1:?usage: check_includes.sh SOURCE_DIR}
cd "$root" || exit 2

violations=0
# rule: a folder's sources must not include headers matching a pattern
forbid() { # folder, extended regex of the included path, what the rule says
  local folder=$1 pattern=$2 rule=$3 file line text
  [[ -d $folder ]] || return 0
  while IFS=: read -r file line text; do
    text=${text#"${text%%[![:space:]]*}"}
    echo "$file:$line: $rule: $text"
    violations=$((violations + 1))
  done < <(grep -rnE --include='*.h' --include='*.hpp' --include='*.cpp' --include='*.cc' \
    "^[[:space:]]*#[[:space:]]*include[[:space:]]*[<\"]($pattern)" "$folder" 2>/dev/null)
}

robot='arm/|sim/|components/'
corba='omniORB4/|omnithread|omniORB|RTM\.hh|RTMExt\.hh|RTMData\.hh|rtm/'
forbid src "$robot|tools/" "the core knows nothing of robots or tools"
forbid src "host/" "the core knows nothing of the host library (runner, access, TLS, leases)"
forbid host "$robot|tools/" "the host library knows nothing of robots or tools"
forbid src/rt "$corba" "the real-time base knows nothing of CORBA or the core"
forbid src/mcap "$corba|rt/" "the MCAP format library knows nothing of CORBA, the core or the real-time base"
forbid arm "$corba" "the arm/CAN library knows nothing of CORBA"
forbid arm "sim/|components/" "the arm/CAN library includes no simulator or component"
forbid sim "$corba" "the simulator knows nothing of CORBA"
forbid sim "components/" "the simulator includes no component"
forbid tools "$robot" "tools include no robot code"
forbid python "$robot" "the Python package includes no robot code"
forbid bench '\.\./|tests/' "benchmarks take tests' code only from the test-support libraries (rtm_test/)"
for folder in bench examples scripts src host arm sim tools python; do
  forbid "$folder" "components/" "nothing outside components/ and tests/ includes a component"
done

# rule: a folder's sources must not call what matches a pattern (comments aside)
forbid_call() { # folder, extended regex, what the rule says
  local folder=$1 pattern=$2 rule=$3 file line text
  [[ -d $folder ]] || return 0
  while IFS=: read -r file line text; do
    text=${text#"${text%%[![:space:]]*}"}
    [[ $text == //* ]] && continue
    echo "$file:$line: $rule: $text"
    violations=$((violations + 1))
  done < <(grep -rnE --include='*.h' --include='*.hpp' --include='*.cpp' --include='*.cc' "$pattern" "$folder" 2>/dev/null)
}
forbid tools/browser "launcher/|serve/|scaffold/|httplib" "the browser knows nothing of the launcher, the web server or the scaffold"
forbid_call tools/browser 'std::(cout|cerr|clog)|fmt::print|(^|[^a-z_])(printf|fprintf|puts)[[:space:]]*\(' "the browser prints nothing"
forbid tools/launcher "serve/|scaffold/|recorder/" "the launcher calls the browser only"
forbid tools/recorder "serve/|scaffold/" "the recorder calls the browser and the launcher only"
forbid tools/serve "scaffold/" "the web server calls the browser and the launcher only"
forbid tools/scaffold "browser/|launcher/|serve/" "the scaffold writes files and asks nothing of a running system"

while IFS=: read -r file line text; do
  [[ $file == */main.cpp ]] && continue
  text=${text#"${text%%[![:space:]]*}"}
  echo "$file:$line: a component's logic stands on the core (host/ is for its main.cpp): $text"
  violations=$((violations + 1))
done < <(grep -rnE --include='*.h' --include='*.cpp' '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]host/' components 2>/dev/null)

if ((violations)); then
  echo "$violations layering violation(s)"
  exit 1
fi
echo "layering: every #include follows the rules"
