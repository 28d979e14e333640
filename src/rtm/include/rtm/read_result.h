// SPDX-License-Identifier: Apache-2.0
#pragma once

namespace rtm {

// What a read learned (Orocos' FlowStatus).
enum class ReadResult {
  NoData,   // nothing was ever stored (FIFO: nothing ever read either)
  OldData,  // the value was read before (FIFO: empty now; out gets the last value read)
  NewData,  // out holds a datum not read before
};

}  // namespace rtm
