// SPDX-License-Identifier: Apache-2.0
// What every integration test starts from: one ORB in the test process, a fresh omniNames on
// a free port, and helpers to run rtm-test-component processes and reach them.
#pragma once

#include "rtm/naming.h"
#include "rtm/orb.h"
#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"

#include <RTMExt.hh>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace rtm_it {

using namespace std::chrono_literals;

// omniORB has one ORB per process: made once, destroyed after the last test.
rtm::Orb& test_orb();

using rtm_test::eventually;

class IntegrationTest : public ::testing::Test {
 protected:
  rtm::Orb& orb() { return test_orb(); }
  rtm::NamingClient naming() const {
    return rtm::NamingClient(test_orb().orb(), rtm::NamingAddress::parse(names_.address()));
  }

  // Starts rtm-test-component --name name and waits until it is bound. The fixture owns the
  // process: TearDown stops it and expects a clean exit (status 0, so no sanitizer report
  // and no crash on the way out) unless the test already ended it.
  rtm_test::ChildProcess& start_component(const std::string& name, std::vector<std::string> extra_args = {});
  void TearDown() override;
  RTM::RtComponentEx_var component(const std::string& name);
  RTM::OutPortEx_var out_port(const std::string& component_name, const std::string& port_name);
  RTM::InPortEx_var in_port(const std::string& component_name, const std::string& port_name);

  rtm_test::OmniNames names_;
  std::vector<std::unique_ptr<rtm_test::ChildProcess>> components_;
};

}  // namespace rtm_it
