// Scratch arrays of prepareMesh's passes (private to core/src).
#pragma once

#include "hdt/huge_pages.hpp" // HugePageScratchAllocator

#include <vector>

namespace hdt {

// Fresh memory's pages are faulted in by the threads that write them first;
// vectors that are written in parallel loops are not zeroed first, and large
// ones get 2 MiB pages (keys scattered over MBs: with 4 KiB pages, a TLB miss
// and often a page fault a write).
template <class T> using Scratch = std::vector<T, HugePageScratchAllocator<T>>;

} // namespace hdt
