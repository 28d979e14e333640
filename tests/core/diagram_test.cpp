// SPDX-License-Identifier: Apache-2.0
// A diagram is checked once, as a value, against the ports of its members: every problem at
// once, each naming both ends.
#include "rtm/component.h"
#include "rtm/data.h"
#include "rtm/diagram.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace {

class Sensor final : public rtm::Component {
 public:
  explicit Sensor(std::string name) : Component(std::move(name), "sensor") {}
  void on_cycle(const rtm::CycleContext&) override {}
  rtm::OutPort<RTM::TimedFloat6>& wrench = add_out_port<RTM::TimedFloat6>("wrench", {"wrench", rtm::wrench_elements()});
  rtm::OutPort<RTM::TimedFloat3>& position = add_out_port<RTM::TimedFloat3>("position");
};

class Controller final : public rtm::Component {
 public:
  explicit Controller(std::string name) : Component(std::move(name), "controller") {}
  void on_cycle(const rtm::CycleContext&) override {}
  rtm::InPort<RTM::TimedFloat6>& wrench = add_in_port<RTM::TimedFloat6>("wrench", {"wrench", rtm::wrench_elements()});
  rtm::InPort<RTM::TimedFloat6>& reference =
      add_in_port<RTM::TimedFloat6>("reference", {"reference", rtm::wrench_elements()});
  rtm::OutPort<RTM::TimedFloat6>& twist = add_out_port<RTM::TimedFloat6>("twist", {"twist", rtm::twist_elements()});
};

class Actuator final : public rtm::Component {
 public:
  explicit Actuator(std::string name) : Component(std::move(name), "actuator") {}
  void on_cycle(const rtm::CycleContext&) override {}
  rtm::InPort<RTM::TimedFloat6>& twist = add_in_port<RTM::TimedFloat6>("twist", {"twist", rtm::twist_elements()});
};

struct Servo {
  Sensor sensor{"sensor0"};
  Controller controller{"controller0"};
  Actuator actuator{"actuator0"};
  rtm::PortCatalogue ports = rtm::catalogue_of({&sensor, &controller, &actuator});
};

rtm::Diagram servo_diagram() {
  return {.name = "servo",
          .members = {{"sensor0"}, {"controller0"}, {"actuator0"}},
          .ticked = true,
          .connections = {{{"sensor0", "wrench"}, {"controller0", "wrench"}},
                          {{"controller0", "twist"}, {"actuator0", "twist"}}}};
}

bool has(const std::vector<std::string>& problems, const std::string& text) {
  return std::any_of(problems.begin(), problems.end(), [&](const std::string& p) { return p == text; });
}

std::string listed(const std::vector<std::string>& problems) {
  std::string out;
  for (const auto& p : problems) out += "\n  " + p;
  return out;
}

TEST(Diagram, ThePapersServoHoldsByPortNameAndByIndex) {
  Servo s;
  EXPECT_NO_THROW(servo_diagram().check(s.ports));
  rtm::Diagram by_index = servo_diagram();
  by_index.connections[0] = {{"sensor0", "out0"}, {"controller0", "in0"}};
  EXPECT_TRUE(by_index.problems(&s.ports).empty()) << listed(by_index.problems(&s.ports));
}

TEST(Diagram, AMissingMemberOrPortIsNamedWithWhatThereIs) {
  Servo s;
  rtm::Diagram d = servo_diagram();
  d.connections[0].to = {"controler0", "wrench"};
  d.connections[1].from = {"controller0", "twst"};
  const auto problems = d.problems(&s.ports);
  EXPECT_TRUE(has(problems, "sensor0.wrench -> controler0.wrench: no member controler0 (members: sensor0, "
                            "controller0, actuator0)"))
      << listed(problems);
  EXPECT_TRUE(has(problems, "controller0.twst -> actuator0.twist: controller0 has no OutPort twst (OutPorts: twist)"))
      << listed(problems);
  EXPECT_EQ(problems.size(), 2u) << listed(problems);
}

TEST(Diagram, DirectionTypeAndUnitsAreCheckedNamingBothEnds) {
  Servo s;
  rtm::Diagram d{.name = "bad",
                 .members = {{"sensor0"}, {"controller0"}, {"actuator0"}},
                 .connections = {{{"controller0", "wrench"}, {"actuator0", "twist"}},
                                 {{"sensor0", "position"}, {"controller0", "reference"}},
                                 {{"sensor0", "wrench"}, {"actuator0", "twist"}}}};
  const auto problems = d.problems(&s.ports);
  EXPECT_TRUE(has(problems, "controller0.wrench -> actuator0.twist: controller0.wrench is an InPort; a connection "
                            "goes from an OutPort to an InPort"))
      << listed(problems);
  EXPECT_TRUE(has(problems, "sensor0.position (RTM::TimedFloat3) -> controller0.reference (RTM::TimedFloat6): "
                            "types differ"))
      << listed(problems);
  EXPECT_TRUE(has(problems, "sensor0.wrench -> actuator0.twist: element 0 is in N at sensor0.wrench and in m/s at "
                            "actuator0.twist"))
      << listed(problems);
}

TEST(Diagram, AnInPortTakesOneWriterAndAConnectionIsListedOnce) {
  Servo s;
  Sensor joystick{"joystick0"};
  rtm::Diagram d = servo_diagram();
  d.members.insert(d.members.begin(), {"joystick0"});
  d.connections.push_back({{"joystick0", "wrench"}, {"controller0", "wrench"}});
  d.connections.push_back({{"sensor0", "wrench"}, {"controller0", "wrench"}});
  const auto ports = rtm::catalogue_of({&joystick, &s.sensor, &s.controller, &s.actuator});
  const auto problems = d.problems(&ports);
  EXPECT_TRUE(has(problems, "controller0.wrench has two writers, sensor0.wrench and joystick0.wrench: an InPort "
                            "takes one"))
      << listed(problems);
  EXPECT_TRUE(has(problems, "sensor0.wrench -> controller0.wrench is listed twice")) << listed(problems);
  EXPECT_EQ(problems.size(), 2u) << listed(problems);
}

TEST(Diagram, ATickedLoopNeedsItsFeedbackDeclaredAndAnUntickedOneDoesNot) {
  Servo s;
  rtm::Diagram d = servo_diagram();
  std::swap(d.members[0], d.members[1]);  // controller0 before sensor0
  auto problems = d.problems(&s.ports);
  ASSERT_EQ(problems.size(), 1u) << listed(problems);
  EXPECT_EQ(problems[0], "sensor0.wrench -> controller0.wrench runs against the tick order (controller0 runs before "
                         "sensor0 in each cycle): list sensor0 first, or declare the connection feedback (read one "
                         "cycle later)");
  d.connections[0].feedback = true;
  EXPECT_TRUE(d.problems(&s.ports).empty()) << listed(d.problems(&s.ports));
  d.connections[0].feedback = false;
  d.ticked = false;  // each member on its own activity: no order to break
  EXPECT_TRUE(d.problems(&s.ports).empty()) << listed(d.problems(&s.ports));
}

TEST(Diagram, EveryProblemIsReportedAtOnceInOneError) {
  rtm::Diagram d = servo_diagram();
  d.period_ns = 2'000'000;
  d.members[2].phase_ns = 2'000'000;
  d.members.push_back({"sensor0"});
  try {
    d.check_structure();
    FAIL() << "the diagram was taken";
  } catch (const rtm::DiagramError& e) {
    EXPECT_EQ(e.problems().size(), 2u) << e.what();
    EXPECT_NE(std::string(e.what()).find("servo: 2 problems"), std::string::npos) << e.what();
    EXPECT_TRUE(has(e.problems(), "member sensor0 is listed twice")) << e.what();
    EXPECT_TRUE(has(e.problems(), "member actuator0: phase 2000000 ns is not within the period [0, 2000000 ns)"))
        << e.what();
  }
}

TEST(Diagram, APortReferenceIsSplitAtTheLastDot) {
  EXPECT_EQ(rtm::PortRef::parse("host.example/sensor0.wrench"), (rtm::PortRef{"host.example/sensor0", "wrench"}));
  EXPECT_THROW(rtm::PortRef::parse("sensor0"), std::invalid_argument);
  EXPECT_THROW(rtm::PortRef::parse("sensor0."), std::invalid_argument);
}

TEST(Diagram, ArrangeFindsEachMemberInWhatACompositeWasGivenInTheDiagramsOrder) {
  const rtm::Diagram d{.name = "d", .members = {{"a"}, {"b"}, {"c"}}};
  EXPECT_EQ(d.arrange({"c", "a", "b"}, "comp"), (std::vector<std::size_t>{1, 2, 0}));
  try {
    d.arrange({"c", "a"}, "comp");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "comp: diagram member b was not given");
  }
  try {
    d.arrange({"c", "a", "b", "a"}, "comp");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "comp: member a is not in the diagram");
  }
}

}  // namespace
