// Storage that the threads of a step share, each piece alone in an aligned pair of cache
// lines. x86 CPUs move lines between cores in aligned 128-byte pairs as well as alone (the
// spatial prefetcher), so a table that both threads read all the time must not share a pair
// with data that one of them writes every step: the share-start table, 12 bytes on the
// general heap next to the threads' step stamps, cost the dumbbells 6 % at two threads
// (docs/benchmarks.md, 2026-11-24).
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
    return static_cast<T*>(::operator new(Bytes(n), std::align_val_t{kThreadSharedAlign}));
  }
  void deallocate(T* p, std::size_t n) noexcept { ::operator delete(p, Bytes(n), std::align_val_t{kThreadSharedAlign}); }
  friend bool operator==(const PairAlignedAllocator&, const PairAlignedAllocator&) { return true; }

 private:
  static std::size_t Bytes(std::size_t n) {
    return (n * sizeof(T) + kThreadSharedAlign - 1) / kThreadSharedAlign * kThreadSharedAlign;
  }
};

// A table the threads read in every step (written between parallel regions).
template <class T>
using SharedTable = std::vector<T, PairAlignedAllocator<T>>;

}  // namespace granary::engine
