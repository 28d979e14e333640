#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# check_includes.sh finds each kind of violation in a small tree made here, names the file,
# line and rule, and passes a tree that keeps the rules.
# usage: check_includes_test.sh <check_includes.sh>
check=$1
# shellcheck source=expect.sh
source "$(dirname "$0")/expect.sh"
tree=$scratch

mkdir -p "$tree"/{src/rtm,src/rt,host,arm/can,sim,tools/rtm,tools/browser,tools/serve,tools/scaffold,components/controller,components/servo,tests/components,bench/can}
echo '#include "rtm/component.h"' >"$tree/components/controller/controller.h"
echo '#include "components/controller/controller.h"' >"$tree/components/servo/servo.h"
echo '#include "host/runner.h"' >"$tree/components/servo/main.cpp"
echo '#include "components/controller/controller.h"' >"$tree/tests/components/controller_test.cpp"
echo '#include "arm/can/bus.h"' >"$tree/sim/drive.cpp"
echo '#include "rt/activity.h"' >"$tree/sim/runner.cpp"
echo '#include "rt/schedule.h"' >"$tree/src/rtm/component.h"
printf '#include <vector>\n#include "rtm/orb.h"\n' >"$tree/tools/rtm/main.cpp"
printf '#include "rtm/component.h"\n#include "host/access.h"\n' >"$tree/host/runner.cpp"
echo '#include "rtm_test/can/attacker.h"' >"$tree/bench/can/attack_bench.cpp"
printf '#include "browser/browser.h"\n#include "launcher/system_file.h"\n' >"$tree/tools/serve/serve.cpp"
printf '#include "rtm/naming.h"\n// no printf (here), std::cout\nstd::string s = "x";\n' >"$tree/tools/browser/browser.cpp"
run_check "$check" "$tree"
expect "a tree that keeps the rules passes" test $status -eq 0

printf '#include <string>\n#include "arm/can/bus.h"\n' >"$tree/src/rtm/runner.cpp"
echo '  #  include <omniORB4/CORBA.h>' >"$tree/arm/can/master.cpp"
echo '#include "RTMExt.hh"' >"$tree/sim/runner.h"
echo '#include "components/actuator/velocity_arm.h"' >"$tree/tools/rtm/units.cpp"
echo '#include "sim/wrench.h"' >"$tree/arm/can/sensor.h"
echo '#include "rtm/log.h"' >"$tree/src/rt/thread.cpp"
echo '#include "host/tls.h"' >"$tree/src/rtm/naming.cpp"
echo '#include "tools/rtm/browser.h"' >"$tree/host/launch.cpp"
echo '#include "../../tests/tools/run_command.h"' >"$tree/bench/cli_bench.cpp"
echo '#include "serve/serve.h"' >"$tree/tools/browser/values.cpp"
printf 'void f() {\n  fmt::print("{}", 1);\n}\n' >"$tree/tools/browser/json.cpp"
echo '#include "browser/browser.h"' >"$tree/tools/scaffold/scaffold.cpp"
printf '#include "rtm/component.h"\n#include "host/runner.h"\n' >"$tree/components/controller/controller.cpp"
run_check "$check" "$tree"
expect "violations fail the check" test $status -eq 1
expect "the core including robot code is named with its line" grep -q "^src/rtm/runner.cpp:2: the core knows nothing of robots" <<<"$output"
expect "the CAN library including omniORB is found (indented, spaced #include)" grep -q "^arm/can/master.cpp:1: the arm/CAN library knows nothing of CORBA" <<<"$output"
expect "the simulator including the IDL stubs is found" grep -q "^sim/runner.h:1: the simulator knows nothing of CORBA" <<<"$output"
expect "tools including a component is found twice (robot code, a component)" test "$(grep -c '^tools/rtm/units.cpp:1:' <<<"$output")" -eq 2
expect "the CAN library including the simulator is found" grep -q "^arm/can/sensor.h:1: the arm/CAN library includes no simulator" <<<"$output"
expect "the real-time base including the core is found" grep -q "^src/rt/thread.cpp:1: the real-time base knows nothing of CORBA" <<<"$output"
expect "the core including the host library is found" grep -q "^src/rtm/naming.cpp:1: the core knows nothing of the host library" <<<"$output"
expect "the host library including tools is found" grep -q "^host/launch.cpp:1: the host library knows nothing of robots or tools" <<<"$output"
expect "a benchmark reaching into tests/ is found" grep -q "^bench/cli_bench.cpp:1: benchmarks take tests' code only from the test-support libraries" <<<"$output"
expect "the browser including the web server is found" grep -q "^tools/browser/values.cpp:1: the browser knows nothing of the launcher" <<<"$output"
expect "the browser printing is found, with its line" grep -q "^tools/browser/json.cpp:2: the browser prints nothing" <<<"$output"
expect "the scaffold asking the browser is found" grep -q "^tools/scaffold/scaffold.cpp:1: the scaffold writes files" <<<"$output"
expect "a component's logic including host/ is found (its main.cpp may)" grep -q "^components/controller/controller.cpp:2: a component's logic stands on the core" <<<"$output"
expect "the count is given" grep -q "^14 layering violation(s)" <<<"$output"

finish
