// SPDX-License-Identifier: Apache-2.0
// Counts heap allocations, so a test can prove that a periodic path allocates nothing.
//
// Global operator new is replaced in allocation_counter.cpp (its own translation unit, so the
// compiler never pairs the replaced new/delete with malloc/free at a call site). Link the
// object library rtm_test_allocation_counter into the test executable that needs it; it is
// kept out of rtm_test_support so that other tests keep the ordinary operator new.
#pragma once

#include <cstdint>

namespace rtm_test {

// operator new calls so far, every thread.
std::uint64_t allocations_total();
// operator new calls so far on the calling thread: for a path measured while other threads
// (fake devices, a hub, the ORB) allocate as they like.
std::uint64_t allocations_on_this_thread();

}  // namespace rtm_test
