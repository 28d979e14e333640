// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<std::uint64_t> g_total{0};
thread_local std::uint64_t t_mine = 0;

void* counted_or_null(std::size_t size) noexcept {
  g_total.fetch_add(1, std::memory_order_relaxed);
  ++t_mine;
  return std::malloc(size == 0 ? 1 : size);
}

void* counted(std::size_t size) {
  if (void* p = counted_or_null(size)) return p;
  throw std::bad_alloc();
}
}  // namespace

std::uint64_t rtm_test::allocations_total() { return g_total.load(std::memory_order_relaxed); }
std::uint64_t rtm_test::allocations_on_this_thread() { return t_mine; }

void* operator new(std::size_t size) { return counted(size); }
void* operator new[](std::size_t size) { return counted(size); }
// The nothrow forms too (std::stable_sort's buffer): every form this file's delete frees must
// come from malloc, or a sanitizer sees its new paired with our free.
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return counted_or_null(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return counted_or_null(size); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
