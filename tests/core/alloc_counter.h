// Counts heap allocations of this test program (operator new replaced in alloc_counter.cpp).
#pragma once

#include <cstdint>

namespace rtm::test {
std::uint64_t allocations();  // operator new calls so far, all threads
}
