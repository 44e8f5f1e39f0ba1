#pragma once
// The GMRF's solver by iterated conditional modes (paper Sec. 3.2.2) on a problem known to be a
// grid's; the public entry points are in core/ground_segmentation.hpp.

#include "core/ground_segmentation.hpp"

#include <tbb/task_arena.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::ground {

// Throws std::invalid_argument unless the problem's graph is a grid's: every forward link matched
// by its backward one and every backward link by its forward one, and of nodes of two colours.
void checkGrid(const GmrfProblem& problem, std::size_t n, tbb::task_arena& arena);

// ICM on a problem known to be a grid's. The first sweep visits every node; later ones only the
// nodes next to one that changed since they were last visited (the others would keep their label:
// nothing they depend on changed), which gives the labels of full sweeps at a fraction of the cost.
IcmResult icm(const GmrfProblem& problem, std::vector<std::uint8_t>& ground, int max_iterations,
              tbb::task_arena& arena);

}  // namespace terrain::ground
