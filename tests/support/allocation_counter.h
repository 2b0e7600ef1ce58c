// Counts the allocations a piece of real-time code makes. Include in exactly ONE source file of a
// test program: it replaces the program's operator new and delete.
//
// Every operator new of the program goes through here; only the calls made on a thread while
// its `g_counting` is set are counted (other threads, such as a trace writer, allocate freely):
//
//     g_allocations = 0;
//     g_counting = true;
//     tick();              // the code under test
//     g_counting = false;
//     EXPECT_EQ(g_allocations, 0);
#pragma once

#include <cstdlib>
#include <new>

namespace {
thread_local bool g_counting = false;
thread_local long g_allocations = 0;
void* counted(std::size_t n) {
  if (g_counting) ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
}  // namespace
void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
// The nothrow forms too (std::stable_sort's buffer uses them and frees through plain delete):
// every form must come from the same allocator.
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
