// Storage that the threads of a step share, in aligned pairs of cache lines of its own. x86
// CPUs move lines between cores in aligned 128-byte pairs as well as alone (the spatial
// prefetcher), so data that one thread writes in a step must not share a pair with data that
// another thread reads or writes (measured: docs/benchmarks.md, 2026-11-24).
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace granary::engine {

inline constexpr std::size_t kThreadSharedAlign = 128;

// Allocates whole aligned pairs of lines, so that nothing else lives in them.
template <class T>
struct PairAlignedAllocator {
  using value_type = T;
  PairAlignedAllocator() = default;
  template <class U>
  PairAlignedAllocator(const PairAlignedAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    return static_cast<T*>(::operator new (Bytes(n), std::align_val_t{kThreadSharedAlign}));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    ::operator delete (p, Bytes(n), std::align_val_t{kThreadSharedAlign});
  }
  friend bool operator==(const PairAlignedAllocator&, const PairAlignedAllocator&) { return true; }

 private:
  static std::size_t Bytes(std::size_t n) {
    return (n * sizeof(T) + kThreadSharedAlign - 1) / kThreadSharedAlign * kThreadSharedAlign;
  }
};

// A vector the threads share in a step: a table they all read (written between parallel
// regions), or an array they write in shares (per body, disc or list entry). Aligned, a share
// boundary at a whole body chunk (64 bodies, 512 bytes of doubles) is a boundary of pairs too.
template <class T>
using SharedVector = std::vector<T, PairAlignedAllocator<T>>;

}  // namespace granary::engine
