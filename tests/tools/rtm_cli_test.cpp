// SPDX-License-Identifier: Apache-2.0
// The `rtm` command-line tool, driven as a user drives it: the real binary against real
// component processes and a real omniNames on a free port.
#include "rtm_test/run_command.h"

#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/free_port.h"
#include "rtm_test/omni_names.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <thread>

namespace {

using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::eventually;
using rtm_test::OmniNames;
using namespace std::chrono_literals;

class RtmCli : public ::testing::Test {
 protected:
  CommandResult rtm(std::vector<std::string> args) {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return rtm_test::run_command(args, {"RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR)});
  }
  json rtm_json(std::vector<std::string> args) {
    args.insert(args.begin(), "--json");
    auto r = rtm(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return json::parse(r.out);
  }
  // Whether `rtm --json args` succeeds with output that `holds`: a condition to wait for.
  bool rtm_json_holds(std::vector<std::string> args, const std::function<bool(const json&)>& holds) {
    args.insert(args.begin(), "--json");
    const auto r = rtm(args);
    if (r.exit_code != 0) return false;
    const json out = json::parse(r.out, nullptr, false);
    if (out.is_discarded()) return false;
    try {
      return holds(out);
    } catch (const json::exception&) {
      return false;  // not there yet
    }
  }
  ChildProcess& talker(const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{TALKER_PATH, "--name", name, "--naming", names_.address()};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return rtm_test::start_bound(talkers_, argv);
  }
  static json find(const json& list, const std::string& name) {
    for (const auto& c : list) {
      if (c["name"] == name) return c;
    }
    return json();
  }
  static const json* port(const json& comp, const std::string& name) {
    for (const auto& p : comp["ports"]) {
      if (p["name"] == name) return &p;
    }
    return nullptr;
  }

  OmniNames names_;
  std::vector<std::unique_ptr<ChildProcess>> talkers_;
};

TEST_F(RtmCli, LsListsComponentsWithStateKindPeriodAndPorts) {
  talker("alpha", {"--period", "5ms", "--on"});
  talker("beta");
  auto r = rtm({"ls"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("alpha"), std::string::npos);
  EXPECT_NE(r.out.find("force:TimedFloat6"), std::string::npos) << r.out;
  auto list = rtm_json({"ls"});
  ASSERT_EQ(list.size(), 2u);
  json a = find(list, "alpha"), b = find(list, "beta");
  EXPECT_EQ(a["state"], "on");
  EXPECT_EQ(b["state"], "off");
  EXPECT_EQ(a["kind"], "talker");
  EXPECT_EQ(a["period_ns"], 5'000'000);
  ASSERT_EQ(a["ports"].size(), 4u);
  EXPECT_EQ(a["ports"][0]["name"], "in0");
  EXPECT_EQ(a["ports"][3]["type"], "RTM::TimedFloat3");
}

TEST_F(RtmCli, LsTakesAComponentsNameAHostOrBoth) {
  talker("alpha");
  talker("beta");
  auto one = rtm_json({"ls", "beta"});
  ASSERT_EQ(one.size(), 1u) << one.dump();
  EXPECT_EQ(one[0]["name"], "beta");
  const std::string host = one[0]["host"];
  EXPECT_EQ(rtm_json({"ls", host}).size(), 2u) << "a bare word is a host as well";
  auto both = rtm_json({"ls", host + "/alpha"});
  ASSERT_EQ(both.size(), 1u);
  EXPECT_EQ(both[0]["name"], "alpha");
  EXPECT_EQ(rtm_json({"ls", "gamma"}).size(), 0u) << "no such name nor host";
  EXPECT_EQ(rtm_json({"ls", "no-such-host/alpha"}).size(), 0u);
  auto names = rtm({"ls", "--names", "alpha"});
  EXPECT_EQ(names.out, "alpha\n");
}

TEST_F(RtmCli, LsLongAddsLatenessAndOverruns) {
  talker("alpha", {"--on"});
  ASSERT_TRUE(eventually([&] {
    return rtm_json_holds({"ls", "-l"}, [](const json& list) {
      return find(list, "alpha").at("timing").at("cycles").get<unsigned long long>() > 0;
    });
  }));
  auto list = rtm_json({"ls", "-l"});
  json a = find(list, "alpha");
  ASSERT_TRUE(a.contains("timing")) << a.dump();
  EXPECT_GT(a["timing"]["cycles"].get<unsigned long long>(), 0u);
  EXPECT_TRUE(a["timing"].contains("lateness_p99_ns"));
  auto text = rtm({"ls", "-l"});
  EXPECT_NE(text.out.find("lateness p50"), std::string::npos) << text.out;
}

TEST_F(RtmCli, LsShowsDeadBindingAsDeadAndCleanRemovesIt) {
  talker("alive");
  auto& doomed = talker("doomed");
  doomed.kill_now();  // SIGKILL: no chance to unbind
  auto list = rtm_json({"ls"});
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(find(list, "doomed")["alive"], false);
  EXPECT_EQ(find(list, "alive")["alive"], true);
  auto text = rtm({"ls"});
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.out.find("dead"), std::string::npos) << text.out;
  auto clean = rtm({"ls", "--clean"});
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_NE(clean.out.find("doomed"), std::string::npos);
  list = rtm_json({"ls"});
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0]["name"], "alive");
}

TEST_F(RtmCli, ConnectDeliversDataAndCatShowsTheSubscriptionAndCounters) {
  talker("src", {"--on"});
  talker("dst");
  auto r = rtm({"connect", "src.force", "dst.in0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(eventually([&] {
    return rtm_json_holds({"cat", "dst"}, [](const json& dst) {
      const json* in0 = port(dst, "in0");
      return in0 != nullptr && in0->at("counters").at("accepted").get<unsigned long long>() > 0;
    });
  }));
  auto src = rtm_json({"cat", "src"});
  const json* force = port(src, "force");
  ASSERT_NE(force, nullptr);
  ASSERT_EQ((*force)["subscriptions"].size(), 1u);
  EXPECT_EQ((*force)["subscriptions"][0]["peer"], "dst.in0");
  EXPECT_EQ((*force)["subscriptions"][0]["type"], "repeated");
  // Two processes of one user on one host: the data go through the port's shared-memory ring.
  EXPECT_EQ((*force)["subscriptions"][0]["path"], "shared memory");
  auto dst = rtm_json({"cat", "dst"});
  EXPECT_GT((*port(dst, "in0"))["counters"]["accepted"].get<unsigned long long>(), 0u);
  auto text = rtm({"cat", "src"});
  EXPECT_NE(text.out.find("-> dst.in0 (repeated, shared memory)"), std::string::npos) << text.out;

  ASSERT_EQ(rtm({"disconnect", "src.force", "dst.in0"}).exit_code, 0);
  src = rtm_json({"cat", "src"});
  EXPECT_TRUE((*port(src, "force"))["subscriptions"].empty());
  auto again = rtm({"disconnect", "src.force", "dst.in0"});
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("is not connected"), std::string::npos) << again.err;
}

TEST_F(RtmCli, ConnectTakesAWholePolicyAndCatShowsItsKindPolicyAndWhatTheInPortKeeps) {
  talker("src", {"--on"});
  talker("dst");
  auto bad = rtm({"connect", "src.force", "dst.in0", "--policy", "depth=deep"});
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("'depth=deep'"), std::string::npos) << bad.err;
  auto refused = rtm({"connect", "src.force", "dst.in0", "--policy", "reader=fifo:4"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("the InPort keeps latest, the connection asks reader=fifo:4"), std::string::npos)
      << refused.err;
  auto r = rtm({"connect", "src.force", "dst.in0", "--policy", "reader=latest depth=32 delivery=thread path=corba"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(repeated reader=latest depth=32 delivery=thread path=corba)"), std::string::npos) << r.out;
  auto src = rtm_json({"cat", "src"});
  const json& sub = (*port(src, "force"))["subscriptions"].at(0);
  EXPECT_EQ(sub["path"], "CORBA") << "path=corba keeps the ring out of it";
  EXPECT_EQ(sub["kind"], "CORBA by thread");
  EXPECT_EQ(sub["policy"], "repeated reader=latest depth=32 delivery=thread call=1000ms path=corba");
  EXPECT_EQ(sub["reader"], "latest");
  auto text = rtm({"cat", "src"});
  EXPECT_NE(text.out.find("CORBA by thread: repeated reader=latest depth=32 delivery=thread call=1000ms path=corba; "
                          "the InPort keeps latest"),
            std::string::npos)
      << text.out;
  auto ls = rtm({"ls", "-l"});
  EXPECT_NE(ls.out.find("force -> dst.in0  CORBA by thread: repeated reader=latest depth=32 delivery=thread call=1000ms "
                        "path=corba"),
            std::string::npos)
      << ls.out;
  ASSERT_EQ(rtm({"disconnect", "src.force", "dst.in0"}).exit_code, 0);
}

TEST_F(RtmCli, PortsMayBeNamedByIndex) {
  talker("src");
  talker("dst");
  auto r = rtm({"connect", "src.out0", "dst.in0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto src = rtm_json({"cat", "src"});
  EXPECT_EQ((*port(src, "force"))["subscriptions"].size(), 1u);
}

TEST_F(RtmCli, ConnectRefusesTypeMismatchNamingBothPortsAndTypes) {
  talker("src");
  talker("dst");
  auto r = rtm({"connect", "src.force", "dst.pos3"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("src.force (RTM::TimedFloat6) -> dst.pos3 (RTM::TimedFloat3): types differ"),
            std::string::npos)
      << r.err;
  auto src = rtm_json({"cat", "src"});
  EXPECT_TRUE((*port(src, "force"))["subscriptions"].empty());
}

TEST_F(RtmCli, ConnectRefusesPortsInTheWrongDirection) {
  talker("src");
  talker("dst");
  auto r = rtm({"connect", "dst.in0", "src.force"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("dst.in0 is an InPort"), std::string::npos) << r.err;
}

TEST_F(RtmCli, UnknownComponentAndUnknownPortAreClearErrors) {
  talker("src");
  auto r = rtm({"cat", "nosuch"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nosuch"), std::string::npos) << r.err;
  auto p = rtm({"get", "src.nosuch"});
  EXPECT_EQ(p.exit_code, 1);
  EXPECT_NE(p.err.find("src has no port 'nosuch' (ports: in0, pos3, force, out3"),
            std::string::npos)
      << p.err;
}

TEST_F(RtmCli, OnAndOffChangeTheState) {
  talker("t");
  ASSERT_EQ(rtm({"on", "t"}).exit_code, 0);
  EXPECT_EQ(rtm_json({"cat", "t"})["state"], "on");
  ASSERT_EQ(rtm({"off", "t"}).exit_code, 0);
  EXPECT_EQ(rtm_json({"cat", "t"})["state"], "off");
  auto r = rtm({"on", "t", "ghost"});
  EXPECT_EQ(r.exit_code, 1);  // one of them failed
  EXPECT_EQ(rtm_json({"cat", "t"})["state"], "on");
}

TEST_F(RtmCli, ComponentInErrorRefusesOnUntilReset) {
  talker("t", {"--fail-after", "5", "--on"});
  json t;
  eventually([&] {  // the 5th cycle throws: wait for the state to say so
    t = rtm_json({"cat", "t"});
    return t["state"] == "error";
  });
  ASSERT_EQ(t["state"], "error");
  EXPECT_NE(t["last_error"].get<std::string>().find("failed on purpose"), std::string::npos) << t.dump();
  auto on = rtm({"on", "t"});
  EXPECT_EQ(on.exit_code, 1);
  EXPECT_NE(on.err.find("`rtm reset` clears it"), std::string::npos) << on.err;
  auto reset = rtm({"reset", "t"});
  ASSERT_EQ(reset.exit_code, 0) << reset.err;
  EXPECT_EQ(rtm_json({"cat", "t"})["state"], "off");
  EXPECT_EQ(rtm({"on", "t"}).exit_code, 0);
}

TEST_F(RtmCli, GetSaysNoDataBeforeTheFirstDatumAndValuesAfter) {
  talker("t");
  auto before = rtm({"get", "t.force"});
  EXPECT_EQ(before.exit_code, 1);
  EXPECT_NE(before.err.find("t.force has no data yet"), std::string::npos) << before.err;
  ASSERT_EQ(rtm({"on", "t"}).exit_code, 0);
  ASSERT_TRUE(eventually([&] { return rtm({"get", "t.force"}).exit_code == 0; }));
  auto after = rtm_json({"get", "t.force"});
  EXPECT_EQ(after["type"], "RTM::TimedFloat6");
  ASSERT_EQ(after["values"].size(), 6u);
  // The talker's ramp: value i is cycle + i.
  EXPECT_DOUBLE_EQ(after["values"][1].get<double>() - after["values"][0].get<double>(), 1.0);
  auto text = rtm({"get", "t.force"});
  EXPECT_NE(text.out.find(" N  "), std::string::npos) << "units as the port describes them: " << text.out;
  EXPECT_NE(text.out.find(" N·m"), std::string::npos) << text.out;
}

TEST_F(RtmCli, CatShowsWhatAComponentSaysOfItselfPortsWithUnitsStatisticsAndParameters) {
  talker("t", {"--on"});
  ASSERT_TRUE(eventually([&] {
    return rtm_json_holds({"cat", "t"}, [](const json& t) {
      return t.at("statistics").at("cycles").at("value").get<double>() > 0.0;
    });
  }));
  auto text = rtm({"cat", "t"});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("test component with TimedFloat6 and TimedFloat3 ports"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("fx fy fz tx ty tz [N N N N·m N·m N·m]"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("x y z [m m m]"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("statistics"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("offset"), std::string::npos) << text.out;
  auto t = rtm_json({"cat", "t"});
  EXPECT_EQ(t["description"], "test component with TimedFloat6 and TimedFloat3 ports");
  const json* force = port(t, "force");
  ASSERT_NE(force, nullptr);
  ASSERT_EQ((*force)["elements"].size(), 6u) << force->dump();
  EXPECT_EQ((*force)["elements"][3]["name"], "tx");
  EXPECT_EQ((*force)["elements"][3]["unit"], "N·m");
  EXPECT_FALSE((*port(t, "in0")).contains("elements")) << "an undescribed port claims no units";
  EXPECT_GT(t["statistics"]["cycles"]["value"].get<double>(), 0.0) << t.dump();
  EXPECT_EQ(t["parameters"]["offset"]["access"], "live");
  EXPECT_EQ(t["parameters"]["offset"]["value"], "0");
  EXPECT_EQ(t["parameters"]["fail_after"]["access"], "when off");
  EXPECT_EQ(t["parameters"]["name"]["access"], "fixed");
  EXPECT_EQ(t["parameters"]["name"]["value"], "t");
  EXPECT_EQ(rtm({"cat", "--names", "t"}).out, "in0\npos3\nforce\nout3\n");
  EXPECT_EQ(rtm({"cat", "--parameters", "t"}).out, "offset\nfail_after\nname\nspin_us\n");
}

TEST_F(RtmCli, SetChangesALiveParameterThatTheNextCyclesUse) {
  talker("t", {"--on"});
  auto r = rtm({"set", "t", "offset", "1000000"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("t.offset = 1000000"), std::string::npos) << r.out;
  ASSERT_TRUE(eventually([&] {
    return rtm_json_holds({"get", "t.force"},
                          [](const json& datum) { return datum.at("values").at(0).get<double>() > 1e6; });
  }));
  auto datum = rtm_json({"get", "t.force"});
  EXPECT_GT(datum["values"][0].get<double>(), 1e6) << datum.dump();
  EXPECT_EQ(rtm_json({"cat", "t"})["parameters"]["offset"]["value"], "1000000");
}

TEST_F(RtmCli, SetRefusesAnUnknownAFixedAWhenOffWhileOnOrABadValueAndChangesNothing) {
  talker("t", {"--on"});
  auto unknown = rtm({"set", "t", "nope", "1"});
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.err.find("t: no parameter 'nope' (parameters: offset, fail_after, name, spin_us)"), std::string::npos)
      << unknown.err;
  auto fixed = rtm({"set", "t", "name", "x"});
  EXPECT_EQ(fixed.exit_code, 1);
  EXPECT_NE(fixed.err.find("'name' is fixed"), std::string::npos) << fixed.err;
  auto while_on = rtm({"set", "t", "fail_after", "5"});
  EXPECT_EQ(while_on.exit_code, 1);
  EXPECT_NE(while_on.err.find("only while t is off"), std::string::npos) << while_on.err;
  auto bad = rtm({"set", "t", "offset", "abc"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("'abc' is not a number"), std::string::npos) << bad.err;
  auto nan = rtm({"set", "t", "offset", "nan"});
  EXPECT_EQ(nan.exit_code, 1);
  auto t = rtm_json({"cat", "t"});
  EXPECT_EQ(t["parameters"]["offset"]["value"], "0");
  EXPECT_EQ(t["parameters"]["fail_after"]["value"], "0");
  EXPECT_EQ(t["state"], "on");
  ASSERT_EQ(rtm({"off", "t"}).exit_code, 0);
  ASSERT_EQ(rtm({"set", "t", "fail_after", "5"}).exit_code, 0);
  EXPECT_EQ(rtm_json({"cat", "t"})["parameters"]["fail_after"]["value"], "5");
}

TEST_F(RtmCli, PutInjectsOneValueTheInPortCounts) {
  talker("t");
  auto r = rtm({"put", "t.in0", "1", "2", "3", "4", "5", "6"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto t = rtm_json({"cat", "t"});
  EXPECT_EQ((*port(t, "in0"))["counters"]["accepted"], 1);
  auto bad = rtm({"put", "t.in0", "1", "2"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("t.in0: RTM::TimedFloat6 takes 6 values, got 2"), std::string::npos) << bad.err;
  EXPECT_EQ((*port(rtm_json({"cat", "t"}), "in0"))["counters"]["accepted"], 1);
}

TEST_F(RtmCli, PutAtARatePutsOnePerGridPointForTheTimeGivenAndEachArrives) {
  talker("t");
  auto r = rtm({"--json", "put", "t.in0", "1", "2", "3", "4", "5", "6", "--rate", "100", "--for", "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json summary = json::parse(r.out);
  const auto sent = summary["put"].get<std::uint64_t>();
  EXPECT_GE(sent, 1u);
  EXPECT_EQ(summary["failed"], 0);
  EXPECT_LE(sent + summary["skipped"].get<std::uint64_t>(), 50u) << "0.5 s of a 10 ms grid has 50 points";
  EXPECT_EQ((*port(rtm_json({"cat", "t"}), "in0"))["counters"]["accepted"], sent) << "every put arrived";
  auto bad = rtm({"put", "t.in0", "1", "2", "3", "4", "5", "6", "--rate", "0.5"});
  EXPECT_EQ(bad.exit_code, 2) << "a rate below 1 Hz is refused: " << bad.err;
  bad = rtm({"put", "t.in0", "1", "2", "3", "4", "5", "6", "--for", "1"});
  EXPECT_EQ(bad.exit_code, 2) << "--for without --rate is refused: " << bad.err;
}

TEST_F(RtmCli, WatchStreamsDataThenUnsubscribes) {
  talker("t", {"--on", "--period", "2ms"});
  const auto csv = std::filesystem::temp_directory_path() / ("rtm-watch-" + std::to_string(::getpid()) + ".csv");
  auto r = rtm({"--json", "watch", "t.force", "--count", "50", "--csv", csv.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream lines(r.out);
  int data = 0;
  double previous = -1;
  json summary;
  for (std::string line; std::getline(lines, line);) {
    auto j = json::parse(line);
    if (j.contains("summary")) {
      summary = j["summary"];
      continue;
    }
    ++data;
    const double v0 = j["values"][0];
    if (previous >= 0) {
      EXPECT_EQ(v0, previous + 1) << "every datum, in the order written";
    }
    previous = v0;
  }
  EXPECT_EQ(data, 50);
  EXPECT_EQ(summary["received"], 50);
  // One user, one host: the watch reads the port's shared-memory ring, no call per datum.
  EXPECT_EQ(summary["path"], "shared memory");
  EXPECT_GE(summary["shared_memory"].get<int>(), 50);
  EXPECT_EQ(summary["dropped_display"], 0);
  std::ifstream csv_in(csv);
  int csv_lines = 0;
  long long first_ns = 0, last_ns = 0;
  for (std::string line; std::getline(csv_in, line);) {
    if (csv_lines++ == 0) continue;  // the header
    last_ns = std::stoll(line.substr(0, line.find(',')));
    if (first_ns == 0) first_ns = last_ns;
  }
  EXPECT_EQ(csv_lines, 51);  // header + data
  ASSERT_GT(last_ns, first_ns);
  EXPECT_NEAR(summary["rate_hz"].get<double>(), 49 * 1e9 / static_cast<double>(last_ns - first_ns), 1e-6)
      << "the rate of the data, by their own stamps: 49 intervals over the time they span";
  std::filesystem::remove(csv);
  auto t = rtm_json({"cat", "t"});
  EXPECT_TRUE((*port(t, "force"))["subscriptions"].empty()) << "watch unsubscribed on exit";
}

TEST_F(RtmCli, WatchWritesItsCsvAsTheDataComeNotOnlyAtTheEnd) {
  talker("t", {"--on", "--period", "100ms"});  // a few lines a second: nowhere near a buffer's worth
  const auto csv = std::filesystem::temp_directory_path() / ("rtm-watch-live-" + std::to_string(::getpid()) + ".csv");
  ChildProcess::Options opts;
  opts.echo_output = false;
  ChildProcess watcher({RTM_CLI_PATH, "--naming", names_.address(), "watch", "t.force", "--csv", csv.string()}, opts);
  const auto lines_in_csv = [&] {
    std::ifstream in(csv);
    int n = 0;
    for (std::string line; std::getline(in, line);) ++n;
    return n;
  };
  eventually([&] { return lines_in_csv() >= 3; }, 10s);
  EXPECT_GE(lines_in_csv(), 3) << "the header and two data, read while rtm watch still runs";
  EXPECT_TRUE(watcher.running());
  watcher.send_signal(SIGINT);
  ASSERT_TRUE(watcher.wait_for_exit(10s).has_value());
  std::filesystem::remove(csv);
}

TEST_F(RtmCli, WatchUnsubscribesOnCtrlC) {
  talker("t", {"--on"});
  ChildProcess::Options opts;
  opts.echo_output = false;
  ChildProcess watcher({RTM_CLI_PATH, "--naming", names_.address(), "watch", "t.force"}, opts);
  watcher.wait_for_line("T", 10s);  // first datum line carries an ISO time stamp
  const json subs = (*port(rtm_json({"cat", "t"}), "force"))["subscriptions"];
  ASSERT_EQ(subs.size(), 1u);
  EXPECT_EQ(subs[0]["peer"], "rtm-watch-" + std::to_string(watcher.pid()) + ".in");
  EXPECT_EQ(subs[0]["path"], "shared memory");
  watcher.send_signal(SIGINT);
  auto status = watcher.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string();
  auto t = rtm_json({"cat", "t"});
  EXPECT_TRUE((*port(t, "force"))["subscriptions"].empty());
}

TEST_F(RtmCli, NamingServiceDownIsOneLineNamingTheAddress) {
  const std::string address = names_.address();
  names_.stop();
  auto r = rtm_test::run_command({RTM_CLI_PATH, "--naming", address, "--timeout", "500", "ls"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(address), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST_F(RtmCli, BadCommandLineExitsWithUsageCode) {
  EXPECT_EQ(rtm({"frobnicate"}).exit_code, 2);
  EXPECT_EQ(rtm({"connect", "only-one-port.out0"}).exit_code, 2);
  EXPECT_EQ(rtm({"get", "noport"}).exit_code, 2);
}

TEST_F(RtmCli, APutOfAValueAFloatCannotHoldIsRefusedNotSentAsInfinity) {
  talker("alpha");
  const auto r = rtm({"put", "alpha.in0", "1e39", "0", "0", "0", "0", "0"});
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("1e+39 is out of the range of RTM::TimedFloat6's float elements"), std::string::npos) << r.err;
  EXPECT_EQ(rtm({"put", "alpha.in0", "3e38", "0", "0", "0", "0", "0"}).exit_code, 0) << "the largest floats go";
}

// ------------------------------------------------------------------ access

// What another user can do to components this user started: read them, change nothing.
void expect_changes_refused_and_reads_allowed(const std::function<CommandResult(std::vector<std::string>)>& other) {
  for (const std::vector<std::string>& change :
       {std::vector<std::string>{"off", "alpha"}, {"on", "beta"}, {"connect", "alpha.force", "beta.in0"},
        {"put", "beta.in0", "0", "0", "1", "0", "0", "0"}, {"set", "alpha", "gain", "2"}}) {
    const auto r = other(change);
    EXPECT_NE(r.exit_code, 0) << change[0] << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("not allowed: only the user who started it may change it"), std::string::npos)
        << change[0] << ": " << r.err;
  }
  const auto ls = other({"ls"});
  EXPECT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_NE(ls.out.find("alpha"), std::string::npos) << ls.out;
}

// Run as the user nobody (needs root to switch user; skipped otherwise); a caller over plain TCP,
// whom no component can tell, is tested in rtm_access_test.cpp.
TEST_F(RtmCli, RunAsTheUserNobodyRtmCanReadButNotChangeComponentsAnotherUserStarted) {
  if (::geteuid() != 0) GTEST_SKIP() << "switching to the user nobody needs root";
  if (::access("/usr/bin/setpriv", X_OK) != 0) GTEST_SKIP() << "no setpriv";
  talker("alpha", {"--on"});
  talker("beta");
  auto as_nobody = [&](std::vector<std::string> args) {
    std::vector<std::string> argv{"/usr/bin/setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--",
                                  RTM_CLI_PATH,       "--naming",      names_.address()};
    argv.insert(argv.end(), args.begin(), args.end());
    return rtm_test::run_command(argv, {"HOME=/nonexistent"});
  };
  const auto probe = as_nobody({"ls"});
  if (probe.exit_code == 126 || probe.exit_code == 127) GTEST_SKIP() << "nobody cannot run " << RTM_CLI_PATH;
  expect_changes_refused_and_reads_allowed(as_nobody);
  EXPECT_EQ(find(rtm_json({"ls"}), "alpha")["state"], "on") << "nobody's off changed it";
}

// ------------------------------------------------------------------ demo

// rtm demo runs the demo installed (or, in a build folder, copied) beside it, and says so when
// there is none.
TEST(RtmDemo, RunsTheDemoBesideItAndNamesTheFileWhenThereIsNone) {
  const auto help = rtm_test::run_command({RTM_CLI_PATH, "demo", "--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find("Usage: rtm demo [options]"), std::string::npos) << help.out;
  const std::filesystem::path alone =
      std::filesystem::temp_directory_path() / ("rtm-demo-test-" + std::to_string(::getpid())) / "bin";
  std::filesystem::create_directories(alone);
  std::filesystem::copy_file(RTM_CLI_PATH, alone / "rtm");
  const auto missing = rtm_test::run_command({(alone / "rtm").string(), "demo"});
  std::filesystem::remove_all(alone.parent_path());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find(alone.parent_path().string() + "/share/rtm/examples/force-servo/demo is missing"),
            std::string::npos)
      << missing.err;
}

// ------------------------------------------------------------------ script

// rtm script exec's the interpreter $RTM_SCRIPT_PYTHON names: here a shell script that prints
// its arguments, one per line in brackets, then PYTHONPATH and the naming and TLS variables.
class RtmScript : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("rtm-script-test-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    fake_python_ = dir_ / "fake-python";
    std::ofstream(fake_python_) << "#!/bin/sh\n"
                                   "for a in \"$@\"; do printf '[%s]\\n' \"$a\"; done\n"
                                   "printf 'PYTHONPATH=%s\\n' \"${PYTHONPATH-unset}\"\n"
                                   "printf 'RTM_NAMING=%s\\n' \"${RTM_NAMING-unset}\"\n"
                                   "printf 'RTM_TLS=%s\\n' \"${RTM_TLS-unset}\"\n";
    std::filesystem::permissions(fake_python_, std::filesystem::perms::owner_all);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // rtm (or another copy of it) with the fake interpreter and a PYTHONPATH that helps nobody.
  CommandResult script(std::vector<std::string> args, const std::string& rtm = RTM_CLI_PATH,
                       const std::string& python = "") {
    args.insert(args.begin(), rtm);
    return rtm_test::run_command(args, {"RTM_SCRIPT_PYTHON=" + (python.empty() ? fake_python_.string() : python),
                                        "PYTHONPATH=/nowhere", "RTM_NAMING=", "RTM_TLS="});
  }
  static std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
  }

  std::filesystem::path dir_;
  std::filesystem::path fake_python_;
};

TEST_F(RtmScript, RunsPythonOnRtmScriptWithTheFileAndEveryWordAfterItUnchanged) {
  const auto r = script({"script", "slide.py", "--name", "s0", "--pose", "", "--reference", "servo0.reference",
                         "--help", "--json", "-x", "--naming=elsewhere"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<std::string> expected{"[-m]",     "[rtm.script]", "[slide.py]",         "[--name]", "[s0]",
                                          "[--pose]", "[]",           "[--reference]",      "[servo0.reference]",
                                          "[--help]", "[--json]",     "[-x]", "[--naming=elsewhere]"};
  const auto out = lines(r.out);
  ASSERT_GE(out.size(), expected.size()) << r.out;
  EXPECT_EQ(std::vector<std::string>(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(expected.size())),
            expected)
      << r.out;
}

TEST_F(RtmScript, PutsTheBuildTreesPackageFirstOnPythonPath) {
  // A build tree of its own (a sanitizer preset builds no Python package): bin/rtm and
  // python/rtm/__init__.py beside it.
  const std::filesystem::path bin = dir_ / "build" / "bin";
  const std::filesystem::path package = dir_ / "build" / "python" / "rtm";
  std::filesystem::create_directories(bin);
  std::filesystem::create_directories(package);
  std::filesystem::copy_file(RTM_CLI_PATH, bin / "rtm");
  auto r = script({"script", "slide.py"}, (bin / "rtm").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\nPYTHONPATH=/nowhere\n"), std::string::npos) << "python/ without the package: unchanged\n"
                                                                        << r.out;
  std::ofstream(package / "__init__.py") << "\n";
  r = script({"script", "slide.py"}, (bin / "rtm").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto real = std::filesystem::canonical(dir_ / "build" / "python");
  EXPECT_NE(r.out.find("\nPYTHONPATH=" + real.string() + ":/nowhere\n"), std::string::npos) << r.out;
}

TEST_F(RtmScript, PutsAnInstalledTreesPackageFirstOnPythonPathAndNoneWhenThereIsNeither) {
  const std::filesystem::path bin = dir_ / "prefix" / "bin";
  std::filesystem::create_directories(bin);
  std::filesystem::copy_file(RTM_CLI_PATH, bin / "rtm");
  auto r = script({"script", "slide.py"}, (bin / "rtm").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\nPYTHONPATH=/nowhere\n"), std::string::npos) << "no package beside it: unchanged\n" << r.out;
  const std::filesystem::path installed = dir_ / "prefix" / "lib" / "python3" / "dist-packages";
  std::filesystem::create_directories(installed);
  // rtm knows its folder by /proc/self/exe: without symbolic links.
  const std::filesystem::path real = std::filesystem::canonical(installed);
  r = script({"script", "slide.py"}, (bin / "rtm").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\nPYTHONPATH=" + real.string() + ":/nowhere\n"), std::string::npos) << r.out;
}

TEST_F(RtmScript, PassesRtmsOwnNamingTlsAndTimeoutOnFirstOnlyWhenGivenSoTheScriptsOwnWin) {
  auto r = script({"--naming", "127.0.0.1:4321", "--tls", "/some/tls", "--timeout", "700", "script", "slide.py",
                   "--naming", "127.0.0.1:9999", "--", "--period", "2ms"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("[-m]\n[rtm.script]\n[--naming]\n[127.0.0.1:4321]\n[--tls]\n[/some/tls]\n[--timeout]\n[0.7]\n"
                        "[slide.py]\n[--naming]\n[127.0.0.1:9999]\n[--]\n[--period]\n[2ms]\nPYTHONPATH=",
                        0),
            0u)
      << "rtm's before the file (rtm.script's --timeout is in s), the script's after\n"
      << r.out;
  EXPECT_NE(r.out.find("\nRTM_NAMING=\n"), std::string::npos) << "the environment left as it was\n" << r.out;
  r = script({"script", "slide.py"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("[-m]\n[rtm.script]\n[slide.py]\nPYTHONPATH=", 0), 0u) << "none given: none passed\n" << r.out;
}

TEST_F(RtmScript, HelpScriptAsksTheScriptRunnerForItsHelpAndHelpIsRtms) {
  auto r = script({"script", "--help-script"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("[-m]\n[rtm.script]\n[--help]\nPYTHONPATH=", 0), 0u) << r.out;
  r = script({"script", "--help"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("run a motion script"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--help-script"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("[rtm.script]"), std::string::npos) << "rtm's own help, not the script's\n" << r.out;
}

TEST_F(RtmScript, NoFileIsAUsageError) {
  const auto r = script({"script"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("rtm script FILE"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("[rtm.script]"), std::string::npos) << r.out;
}

TEST_F(RtmScript, AMissingPythonIsAClearErrorWithExitStatus2) {
  const auto r = script({"script", "slide.py"}, RTM_CLI_PATH, (dir_ / "no-python3").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("rtm script needs " + (dir_ / "no-python3").string() +
                       " and RTM's Python package (python3-numpy): scripts/deps.sh installs them"),
            std::string::npos)
      << r.err;
}

// The real interpreter on a script that is not there: tests/python/test_motion.py
// (test_rtm_script_refuses_what_it_cannot_run), where the Python package is built.

// ------------------------------------------------------------------ up / down

class RtmUpDown : public RtmCli {
 protected:
  std::filesystem::path write_system(const std::string& yaml) {
    dir_ = std::filesystem::temp_directory_path() / ("rtm-up-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    auto file = dir_ / "trio.yaml";
    std::ofstream(file) << yaml;
    return file;
  }
  CommandResult rtm_env(std::vector<std::string> args) {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return rtm_test::run_command(args, {"RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR) + ":" + RTM_BIN_DIR,
                                        "XDG_RUNTIME_DIR=" + dir_.string()},
                                 std::chrono::seconds(30));
  }
  void TearDown() override {
    if (!dir_.empty()) {
      rtm_env({"down", "trio"});  // in case a test failed half-way
      std::filesystem::remove_all(dir_);
    }
  }
  std::filesystem::path dir_;
};

TEST_F(RtmUpDown, UpStartsConnectsAndTurnsOnDownStopsEveryProcess) {
  auto file = write_system(R"(
name: trio
components:
  - {name: a, command: [rtm-test-talker, --period, 2ms]}
  - {name: b, command: rtm-test-talker}
  - {name: c, command: rtm-test-talker}
connections:
  - {from: a.force, to: b.in0}
  - {from: b.force, to: c.in0}
activate: [a, b]
)");
  auto up = rtm_env({"--json", "up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.err << up.out;
  auto started = json::parse(up.out);
  ASSERT_EQ(started["processes"].size(), 3u);
  std::vector<pid_t> pids;
  for (const auto& p : started["processes"]) pids.push_back(p["pid"].get<pid_t>());

  auto list = rtm_json({"ls"});
  EXPECT_EQ(find(list, "a")["state"], "on");
  EXPECT_EQ(find(list, "b")["state"], "on");
  EXPECT_EQ(find(list, "c")["state"], "off");
  EXPECT_EQ((*port(rtm_json({"cat", "a"}), "force"))["subscriptions"][0]["peer"], "b.in0");

  auto again = rtm_env({"up", file.string()});
  EXPECT_EQ(again.exit_code, 1) << "a system already up is not started twice";
  EXPECT_NE(again.err.find("already up"), std::string::npos) << again.err;

  auto down = rtm_env({"down", file.string()});
  ASSERT_EQ(down.exit_code, 0) << down.err;
  for (pid_t pid : pids) {
    EXPECT_NE(::kill(pid, 0) == 0 && std::filesystem::exists("/proc/" + std::to_string(pid)) &&
                  [&] {
                    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
                    std::string s;
                    std::getline(stat, s);
                    auto st = s.substr(s.rfind(')') + 2, 1);
                    return st != "Z";
                  }(),
              true)
        << "process " << pid << " still runs after down";
  }
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "every name unbound";
  auto twice = rtm_env({"down", "trio"});
  EXPECT_EQ(twice.exit_code, 1);
  EXPECT_NE(twice.err.find("is it up?"), std::string::npos) << twice.err;
}

// host: a and b in one rtm-container, c alone; the wiring between a and b in-process, each
// member switched on its own, the page's save writes the host back, and down stops the
// container once.
TEST_F(RtmUpDown, UpRunsAHostsMembersInOneContainerWiredInProcessAndDownStopsIt) {
  auto file = write_system(R"(
name: trio
components:
  - {name: a, command: [rtm-test-talker, --period, 2ms], host: cell0}
  - {name: c, command: rtm-test-talker}
  - {name: b, command: rtm-test-talker, host: cell0, parameters: {offset: 2}}
connections:
  - {from: a.force, to: b.in0}
  - {from: b.force, to: c.in0}
activate: [a]
)");
  auto up = rtm_env({"--json", "up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.err << up.out;
  const json started = json::parse(up.out);
  ASSERT_EQ(started["processes"].size(), 2u) << started.dump();
  EXPECT_EQ(started["processes"][0]["name"], "cell0");
  EXPECT_EQ(started["processes"][0]["members"], (json{"a", "b"}));
  const auto pid_of = [&](const std::string& name) {
    return rtm_json({"cat", name})["statistics"]["pid"]["value"].get<double>();
  };
  const double container = started["processes"][0]["pid"].get<double>();
  EXPECT_EQ(pid_of("a"), container);
  EXPECT_EQ(pid_of("b"), container);
  EXPECT_NE(pid_of("c"), container);
  const json a = rtm_json({"cat", "a"}), b = rtm_json({"cat", "b"});
  EXPECT_TRUE((*port(a, "force"))["subscriptions"][0]["in_process"].get<bool>()) << a.dump();
  EXPECT_FALSE((*port(b, "force"))["subscriptions"][0]["in_process"].get<bool>()) << "c is another process";
  EXPECT_EQ(a["state"], "on");
  EXPECT_EQ(b["state"], "off");
  EXPECT_EQ(b["parameters"]["offset"]["value"], "2");

  auto down = rtm_env({"down", "trio"});
  ASSERT_EQ(down.exit_code, 0) << down.err;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "every name unbound";
  EXPECT_FALSE(std::filesystem::exists("/proc/" + std::to_string(static_cast<long>(container)) + "/exe"))
      << "the container still runs";
}

TEST_F(RtmUpDown, UpNamesTheComponentThatDidNotComeUpAndLeavesNothingRunning) {
  auto file = write_system(R"(
name: trio
components:
  - {name: good, command: rtm-test-talker}
  - {name: broken, command: [rtm-test-talker, --no-such-option]}
)");
  auto up = rtm_env({"up", file.string()});
  EXPECT_EQ(up.exit_code, 1);
  EXPECT_NE(up.err.find("broken exited before it was bound"), std::string::npos) << up.err;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "good was stopped and unbound too";
}

TEST_F(RtmUpDown, UpChecksTheWholeWiringFirstNamingEveryProblemAndConnectsNothing) {
  auto file = write_system(R"(
name: trio
components:
  - {name: a, command: rtm-test-talker}
  - {name: b, command: rtm-test-talker}
connections:
  - {from: a.force, to: b.in0}
  - {from: a.force, to: b.pos3}
  - {from: a.forse, to: b.out3}
activate: [a, b]
)");
  auto up = rtm_env({"up", file.string()});
  EXPECT_EQ(up.exit_code, 1) << up.out;
  EXPECT_NE(up.err.find("the wiring does not hold, nothing was connected"), std::string::npos) << up.err;
  EXPECT_NE(up.err.find("a.force (RTM::TimedFloat6) -> b.pos3 (RTM::TimedFloat3): types differ"), std::string::npos)
      << up.err;
  EXPECT_NE(up.err.find("a.forse -> b.out3: a has no OutPort forse (OutPorts: force, out3)"), std::string::npos)
      << up.err;
  EXPECT_NE(up.err.find("a.forse -> b.out3: b.out3 is an OutPort; a connection goes from an OutPort to an InPort"),
            std::string::npos)
      << up.err;
  EXPECT_EQ(up.out.find("connected"), std::string::npos) << "a connection was made first:\n" << up.out;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "what was started is stopped again";
}

TEST_F(RtmUpDown, UpSetsTheFilesParametersBeforeItTurnsTheComponentOn) {
  // fail_after may change only while the talker is off: set after `on`, it would be refused.
  auto file = write_system(
      "components:\n  - name: a\n    command: rtm-test-talker\n    parameters: {offset: 7, fail_after: 1000}\n"
      "activate: [a]\n");
  auto up = rtm_env({"up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.err << up.out;
  EXPECT_NE(up.out.find("set a offset = 7"), std::string::npos) << up.out;
  const json a = rtm_json({"cat", "a"});
  EXPECT_EQ(a["state"], "on");
  EXPECT_EQ(a["parameters"]["offset"]["value"], "7");
  EXPECT_EQ(a["parameters"]["fail_after"]["value"], "1000");
}

TEST_F(RtmUpDown, UpWithASetPutsItsValuesOverTheParametersAndAnUnknownSetStartsNothing) {
  auto file = write_system(
      "components:\n  - name: a\n    command: rtm-test-talker\n    parameters: {offset: 7, fail_after: 1000}\n"
      "    parameter_sets: {quick: {fail_after: 5}}\n");
  auto unknown = rtm_env({"up", file.string(), "--set", "slow"});
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.err.find("no component has the parameter set 'slow' (sets: quick)"), std::string::npos)
      << unknown.err;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "nothing started";
  auto up = rtm_env({"up", file.string(), "--set", "quick"});
  ASSERT_EQ(up.exit_code, 0) << up.err << up.out;
  const json a = rtm_json({"cat", "a"});
  EXPECT_EQ(a["parameters"]["offset"]["value"], "7") << "the file's parameters";
  EXPECT_EQ(a["parameters"]["fail_after"]["value"], "5") << "the set's value over them";
}

TEST_F(RtmUpDown, UpWithAParameterTheComponentRefusesSaysWhyOnceAndLeavesNothingRunning) {
  auto file = write_system("components:\n  - {name: a, command: rtm-test-talker, parameters: {nope: 1}}\n");
  auto up = rtm_env({"up", file.string()});
  EXPECT_EQ(up.exit_code, 1);
  EXPECT_NE(up.err.find("a: no parameter 'nope' (parameters: offset, fail_after, name, spin_us)"), std::string::npos)
      << up.err;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "what up started is stopped again";
}

TEST_F(RtmUpDown, UpWithAMissingProgramStartsNothing) {
  auto file = write_system("components: [{name: x, command: rtm-no-such-component}]\n");
  auto up = rtm_env({"up", file.string()});
  EXPECT_EQ(up.exit_code, 1);
  EXPECT_NE(up.err.find("program 'rtm-no-such-component' not found"), std::string::npos) << up.err;
}

TEST_F(RtmUpDown, UpWithTheNamingServiceDownStartsNothingAndSaysWhereItLooked) {
  auto file = write_system("components: [{name: a, command: rtm-test-talker}]\nactivate: [a]\n");
  const std::string nowhere = "127.0.0.1:" + std::to_string(rtm_test::free_loopback_port());
  auto up = rtm_test::run_command({RTM_CLI_PATH, "--naming", nowhere, "up", file.string()},
                                  {"RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR), "XDG_RUNTIME_DIR=" + dir_.string()},
                                  std::chrono::seconds(30));
  EXPECT_EQ(up.exit_code, 1);
  EXPECT_NE(up.err.find("naming service at " + nowhere + " unreachable"), std::string::npos) << up.err;
  EXPECT_EQ((up.out + up.err).find("started a"), std::string::npos) << up.out << up.err;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir_))
    EXPECT_NE(entry.path().extension(), ".log") << "a component was started: " << entry.path();
}

TEST_F(RtmUpDown, ANameThatEscapesTheRuntimeFolderIsRefusedBeforeAnythingStarts) {
  for (const std::string& yaml : {std::string("name: ../x\ncomponents: [{name: a, command: rtm-test-talker}]\n"),
                                  std::string("components: [{name: /var/log/dpkg, command: rtm-test-talker}]\n")}) {
    auto up = rtm_env({"up", write_system(yaml).string()});
    EXPECT_NE(up.exit_code, 0) << yaml;
    EXPECT_NE(up.err.find("1 to 64 of A-Z a-z 0-9 _ - ."), std::string::npos) << up.err;
    EXPECT_TRUE(rtm_json({"ls"}).empty()) << "nothing started";
  }
  const auto talker = rtm_test::run_command({TALKER_PATH, "--name", "../x", "--naming", names_.address()});
  EXPECT_EQ(talker.exit_code, 2) << talker.err;
  EXPECT_NE(talker.err.find("component name '../x'"), std::string::npos) << talker.err;
}

TEST_F(RtmUpDown, UpRefusesANameBoundToAnotherSystemsComponentAndTurnsNothingOn) {
  talker("a");  // another system's a, off
  auto up = rtm_env({"up", write_system("components: [{name: a, command: rtm-test-talker}]\nactivate: [a]\n").string()});
  EXPECT_NE(up.exit_code, 0) << up.out;
  EXPECT_NE(up.err.find("a is bound to another process (pid " + std::to_string(talkers_.back()->pid()) + ")"),
            std::string::npos)
      << up.err;
  EXPECT_EQ(find(rtm_json({"ls"}), "a")["state"], "off") << "rtm up turned on another system's component";
}

TEST_F(RtmUpDown, UpThatCannotWriteItsStateFailsAndLeavesNothingRunning) {
  auto file = write_system("name: trio\ncomponents: [{name: a, command: rtm-test-talker}]\n");
  std::filesystem::create_directories(dir_ / "rtm" / "trio.state.yaml.tmp");  // the write cannot happen
  auto up = rtm_env({"up", file.string()});
  EXPECT_NE(up.exit_code, 0) << up.out;
  EXPECT_NE(up.err.find("cannot write the state of system 'trio'"), std::string::npos) << up.err;
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "a still bound: its process was left running";
  std::filesystem::remove_all(dir_ / "rtm" / "trio.state.yaml.tmp");
}

TEST_F(RtmUpDown, CtrlCDuringUpStopsWhatItStartedAndExits130) {
  auto file = write_system(R"(
name: slow
components:
  - {name: a, command: rtm-test-talker}
  - {name: never, command: [sh, -c, "sleep 30"]}
activate: [a]
)");
  rtm_test::ChildProcess::Options quiet;
  quiet.echo_output = false;
  quiet.extra_env = {"RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR), "XDG_RUNTIME_DIR=" + dir_.string()};
  rtm_test::ChildProcess up({RTM_CLI_PATH, "--naming", names_.address(), "up", file.string()}, quiet);
  up.wait_for_line("bound a", 20s);  // now waiting for `never`
  up.send_signal(SIGINT);
  const auto status = up.wait_for_exit(20s);
  ASSERT_TRUE(status.has_value()) << "rtm up still runs after Ctrl-C";
  EXPECT_TRUE(status->exited && status->code == 130) << status->to_string() << "\n" << up.output();
  EXPECT_NE(up.output().find("interrupted: stopped what `rtm up slow` had started"), std::string::npos) << up.output();
  EXPECT_TRUE(rtm_json({"ls"}).empty()) << "a was left running";
  EXPECT_FALSE(std::filesystem::exists(dir_ / "rtm" / "slow.state.yaml")) << "a state file of a system that is not up";
}

}  // namespace
