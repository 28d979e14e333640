// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<std::uint64_t> g_total{0};
thread_local std::uint64_t t_mine = 0;

void* counted(std::size_t size) {
  g_total.fetch_add(1, std::memory_order_relaxed);
  ++t_mine;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
}  // namespace

std::uint64_t rtm_test::allocations_total() { return g_total.load(std::memory_order_relaxed); }
std::uint64_t rtm_test::allocations_on_this_thread() { return t_mine; }

void* operator new(std::size_t size) { return counted(size); }
void* operator new[](std::size_t size) { return counted(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
