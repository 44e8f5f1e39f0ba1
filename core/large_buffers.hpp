#pragma once
// Buffers of millions of elements (a voxel map's voxels, the segmentation's per-voxel arrays)
// backed by huge pages where the kernel offers them.
//
// Memory a process touches for the first time costs a page fault per 4 KiB page. On a virtual
// machine a fault can take 10 us, so filling 84 MB of fresh memory took 220 ms where writing it
// took 8 ms. Linux backs a range with 2 MiB pages when asked to (madvise MADV_HUGEPAGE, which
// transparent huge pages in their default "madvise" mode wait for), 512 times fewer faults. The
// advice changes where the bytes live, never their values; where it is not available it is left
// out.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace terrain {

// the size of a huge page, and the least block worth advising [bytes]
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

// Asks the kernel to back the whole huge pages inside [data, data + bytes) with huge pages, before
// they are first touched. A hint: nothing happens where the kernel declines it.
inline void adviseHugePages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes < kHugePageBytes) return;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  const std::uintptr_t last = (begin + bytes) & ~(kHugePageBytes - 1);
  if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)data, (void)bytes;
#endif
}

// Makes room for n elements in v without touching it: a vector that must grow to n takes a new
// block (at least twice its capacity, as push_back would) advised for huge pages before its
// elements are moved or written in. Elements and size are unchanged.
template <class T>
void reserveLarge(std::vector<T>& v, std::size_t n) {
  if (n <= v.capacity()) return;
  std::vector<T> grown;
  grown.reserve(std::max(n, 2 * v.capacity()));
  adviseHugePages(grown.data(), grown.capacity() * sizeof(T));
  grown.insert(grown.end(), std::make_move_iterator(v.begin()), std::make_move_iterator(v.end()));
  v.swap(grown);
}

// v.resize(n), its new elements written into memory advised for huge pages.
template <class T>
void resizeLarge(std::vector<T>& v, std::size_t n) {
  reserveLarge(v, n);
  v.resize(n);
}

// v.assign(n, value), likewise.
template <class T>
void assignLarge(std::vector<T>& v, std::size_t n, const T& value) {
  reserveLarge(v, n);
  v.assign(n, value);
}

}  // namespace terrain
