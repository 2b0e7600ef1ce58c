// The allocation counter of allocation_counter.h: the flag and count, and how allocations are
// seen (the sanitizer's hooks, or operator new and delete replaced). One definition for every
// test program that links the support library; a program whose sources never read the count
// still gets it (the replaced operators are found before the standard library's), harmlessly.
#include "tests/support/allocation_counter.h"

#include <cstdlib>
#include <new>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MACHPLAN_COUNT_WITH_ASAN_HOOKS 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) && !defined(MACHPLAN_COUNT_WITH_ASAN_HOOKS)
#define MACHPLAN_COUNT_WITH_ASAN_HOOKS 1
#endif

thread_local bool g_counting = false;
thread_local long g_allocations = 0;

#ifdef MACHPLAN_COUNT_WITH_ASAN_HOOKS
#include <sanitizer/allocator_interface.h>

namespace {
void count_allocation(const volatile void*, std::size_t) {
  if (g_counting) ++g_allocations;
}
void count_free(const volatile void*) {}
// Installed while the program's statics are made, before any test runs.
[[maybe_unused]] const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(count_allocation, count_free);
}  // namespace
#else
namespace {
void* counted(std::size_t n) {
  if (g_counting) ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
}  // namespace
void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  if (g_counting) ++g_allocations;
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#endif
