// Heap allocations made so far by this test binary: global operator new is replaced in
// allocation_counter.cpp, its own translation unit so the compiler never sees a replaced
// new/delete pair inlined together.
#pragma once

namespace rtm::sim::testing {
long allocations_so_far();
}  // namespace rtm::sim::testing
