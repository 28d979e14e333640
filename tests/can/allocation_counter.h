// Counts heap allocations made by the calling thread (operator new is replaced in
// allocation_counter.cpp), so a test can prove a periodic path allocates nothing while other
// threads (the fake devices, the hub) allocate as they like.
#pragma once

#include <cstddef>

namespace rtm::can::testing {
std::size_t allocations_on_this_thread();
}  // namespace rtm::can::testing
