// Counts the allocations a piece of real-time code makes. Include in exactly ONE source file of a
// test program.
//
// Only the allocations made on a thread while its `g_counting` is set are counted (other
// threads, such as a trace writer, allocate freely):
//
//     g_allocations = 0;
//     g_counting = true;
//     tick();              // the code under test
//     g_counting = false;
//     EXPECT_EQ(g_allocations, 0);
//
// How they are seen:
//   * Under AddressSanitizer (the test build) the sanitizer's own allocator reports every
//     allocation, operator new in all its forms and malloc alike, to a hook installed before
//     main. Nothing is replaced, so memory is always freed by the allocator that gave it (a
//     replaced operator new beside the sanitizer's can pair one allocator's new with the
//     other's delete: libstdc++'s std::stable_sort takes its buffer with the nothrow form).
//   * Without it, the program's operator new and delete are replaced, every form of them
//     through malloc and free.
#pragma once

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

namespace {
thread_local bool g_counting = false;
thread_local long g_allocations = 0;
}  // namespace

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
