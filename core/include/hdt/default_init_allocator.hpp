// An allocator for bulk arrays that are always written right after they are
// sized.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace hdt {

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

template <class T> using DefaultInitAllocator = DefaultInit<std::allocator<T>>;

} // namespace hdt
