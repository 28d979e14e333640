// SPDX-License-Identifier: Apache-2.0
// One ORB for a whole test program, for tests that encode or decode CDR (its strings need the
// code sets omniORB sets up when it starts). Register it once per program:
//   const auto* const kOrb = ::testing::AddGlobalTestEnvironment(new rtm_test::OrbEnvironment);
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "rtm/orb.h"

namespace rtm_test {

class OrbEnvironment : public ::testing::Environment {
 public:
  void SetUp() override { orb_ = std::make_unique<rtm::Orb>(); }
  void TearDown() override { orb_.reset(); }

 private:
  std::unique_ptr<rtm::Orb> orb_;
};

}  // namespace rtm_test
