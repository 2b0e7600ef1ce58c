// Counts the allocations a piece of real-time code makes (defined in allocation_counter.cpp, in
// the test support library; any number of a test program's sources may include this).
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

// Set on a thread while its allocations are counted; the count.
extern thread_local bool g_counting;
extern thread_local long g_allocations;
