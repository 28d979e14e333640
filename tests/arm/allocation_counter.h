// Counts heap allocations made by the calling thread between start and stop, through a
// replaced global operator new (in allocation_counter.cpp, its own translation unit so the
// compiler does not pair the replaced new/delete with malloc/free at call sites).
#pragma once

namespace rtm::test {

void startCountingAllocations();
// Returns how many allocations the calling thread made since startCountingAllocations().
long stopCountingAllocations();

}  // namespace rtm::test
