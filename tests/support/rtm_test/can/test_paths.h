// SPDX-License-Identifier: Apache-2.0
// A private temporary directory per test for hub sockets; removed at the end.
#pragma once

#include "rtm_test/temp_dir.h"

namespace rtm::can::testing {

class TempDir : public rtm_test::TempDir {
 public:
  TempDir() : rtm_test::TempDir("rtm-can") {}
};

}  // namespace rtm::can::testing
