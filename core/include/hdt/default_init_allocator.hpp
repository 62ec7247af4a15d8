// An allocator for bulk arrays that are always written right after they are
// sized.
#pragma once

#include "hdt/warm_pages.hpp"

#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace hdt {

// std::allocator whose resize(n) leaves new elements default-initialised
// (for uint32_t: unwritten). The leaf grids of a volume are always written
// right after they are sized (copy-back, file read, builder), and a
// value-initialising resize would first touch every page of several GB in
// one thread: the copy-back then could not run at the interconnect's speed.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U> struct rebind { using other = DefaultInitAllocator<U>; };
  DefaultInitAllocator() noexcept = default;
  template <class U> DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  // Reserved warm pages where they fit (warm_pages.hpp): a leaf-word array
  // reserved while the device got ready is copied into at memory speed.
  T* allocate(size_t n) {
    if (n <= SIZE_MAX / sizeof(T))
      if (void* p = detail::takeWarmPages(n * sizeof(T))) return static_cast<T*>(p);
    return std::allocator<T>::allocate(n);
  }
  void deallocate(T* p, size_t n) noexcept {
    if (!detail::returnWarmPages(p, n * sizeof(T))) std::allocator<T>::deallocate(p, n);
  }
  template <class U> void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A> void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
template <class T, class U>
bool operator==(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept { return true; }
template <class T, class U>
bool operator!=(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept { return false; }

} // namespace hdt
