// The exact GMRF minimum by s-t min-cut, with the Boykov-Kolmogorov max-flow of libmaxflow (GPL-3).
#include "core/ground_segmentation.hpp"

#include <maxflow/graph.h>

#include <algorithm>
#include <memory>

namespace terrain {

struct MinCutSolver::Graph {
  maxflow::Graph<double, double, double> g;
  Graph(int nodes, int edges) : g(nodes, edges) {}
};

MinCutSolver::MinCutSolver() = default;
MinCutSolver::~MinCutSolver() = default;

void MinCutSolver::solve(const GmrfProblem& p, std::vector<std::uint8_t>& ground) {
  using Flow = maxflow::Graph<double, double, double>;
  const int n = static_cast<int>(ground.size());
  int pairs = 0;
  for (std::uint32_t u : p.next) pairs += u != GmrfProblem::kNone;
  // the graph keeps its arrays on reset (and grows them as nodes and edges are added)
  if (graph_) {
    graph_->g.reset();
  } else {
    graph_ = std::make_unique<Graph>(n, pairs);
  }
  Flow& g = graph_->g;
  g.add_node(n);
  // source side = ground. A node on the source side cuts its sink link, so the sink capacity is
  // the cost of "ground"; shifting both costs by their minimum keeps capacities non-negative.
  for (int v = 0; v < n; ++v) {
    const double m = std::min(p.unary_ground[v], p.unary_nonground[v]);
    g.add_tweights(v, p.unary_nonground[v] - m, p.unary_ground[v] - m);
  }
  // a pair costs -w when equal and +w when different: 2w more when the cut separates it
  for (int v = 0; v < n; ++v) {
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t u = p.next[3 * v + a];
      const double w = p.weight[3 * v + a];
      if (u != GmrfProblem::kNone) g.add_edge(v, static_cast<int>(u), 2 * w, 2 * w);
    }
  }
  g.maxflow();
  for (int v = 0; v < n; ++v) ground[v] = g.what_segment(v) == Flow::SOURCE ? 1 : 0;
}

void solveMinCut(const GmrfProblem& p, std::vector<std::uint8_t>& ground) { MinCutSolver().solve(p, ground); }

}  // namespace terrain
