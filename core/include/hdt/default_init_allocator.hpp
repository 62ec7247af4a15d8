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

// std::allocator that takes reserved warm pages where they fit
// (warm_pages.hpp): a leaf-word array reserved while the device got ready is
// copied into at memory speed.
template <class T>
struct WarmPageAllocator : std::allocator<T> {
  template <class U> struct rebind { using other = WarmPageAllocator<U>; };
  WarmPageAllocator() noexcept = default;
  template <class U> WarmPageAllocator(const WarmPageAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    if (n <= SIZE_MAX / sizeof(T))
      if (void* p = detail::takeWarmPages(n * sizeof(T))) return static_cast<T*>(p);
    return std::allocator<T>::allocate(n);
  }
  void deallocate(T* p, size_t n) noexcept {
    if (!detail::returnWarmPages(p, n * sizeof(T))) std::allocator<T>::deallocate(p, n);
  }
};
template <class T, class U>
bool operator==(const WarmPageAllocator<T>&, const WarmPageAllocator<U>&) noexcept { return true; }
template <class T, class U>
bool operator!=(const WarmPageAllocator<T>&, const WarmPageAllocator<U>&) noexcept { return false; }

// An allocator like `Base` whose resize(n) leaves new elements
// default-initialised (for plain data: unwritten). The leaf grids of a volume
// and the builders' scratch arrays are always written (often in parallel)
// right after they are sized; a value-initialising resize would first touch
// every page of several GB in one thread, and the copy-back then could not
// run at the interconnect's speed.
template <class Base>
struct DefaultInit : Base {
  template <class U> struct rebind {
    using other = DefaultInit<typename std::allocator_traits<Base>::template rebind_alloc<U>>;
  };
  DefaultInit() noexcept = default;
  template <class B> DefaultInit(const DefaultInit<B>& other) noexcept : Base(static_cast<const B&>(other)) {}
  template <class U> void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A> void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
template <class A, class B>
bool operator==(const DefaultInit<A>& a, const DefaultInit<B>& b) noexcept {
  return static_cast<const A&>(a) == static_cast<const B&>(b);
}
template <class A, class B>
bool operator!=(const DefaultInit<A>& a, const DefaultInit<B>& b) noexcept { return !(a == b); }

template <class T> using DefaultInitAllocator = DefaultInit<WarmPageAllocator<T>>;

} // namespace hdt
