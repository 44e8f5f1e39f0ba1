#pragma once
// How the ground segmentation's parallel loops are cut and where they run, so that their results
// do not depend on the thread count.

#include <tbb/task_arena.h>

#include <cstddef>

namespace terrain::ground {

// fixed chunks of nodes, so that sums over them come out the same whatever the thread count
inline constexpr std::size_t kChunks = 64;

// the arena the parallel loops run in: `threads` workers, or TBB's default for 0
inline tbb::task_arena arenaFor(int threads) {
  return tbb::task_arena(threads > 0 ? threads : tbb::task_arena::automatic);
}

}  // namespace terrain::ground
