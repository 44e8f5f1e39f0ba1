#include "core/ground/gmrf.hpp"

#include "core/ground/parallel.hpp"

#include <tbb/parallel_for.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace terrain {

void GmrfProblem::resize(std::size_t n) {
  unary_ground.assign(n, 0.0f);
  unary_nonground.assign(n, 0.0f);
  next.assign(3 * n, kNone);
  prev.assign(3 * n, kNone);
  weight.assign(3 * n, 0.0f);
  parity.assign(n, 0);
}

double gmrfEnergy(const GmrfProblem& p, const std::vector<std::uint8_t>& ground) {
  const std::size_t n = ground.size();
  std::vector<double> part(ground::kChunks, 0.0);
  tbb::parallel_for(std::size_t{0}, ground::kChunks, [&](std::size_t c) {
    double e = 0;
    for (std::size_t v = n * c / ground::kChunks; v < n * (c + 1) / ground::kChunks; ++v) {
      e += ground[v] ? p.unary_ground[v] : p.unary_nonground[v];
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t u = p.next[3 * v + a];
        if (u != GmrfProblem::kNone) e += ground[v] == ground[u] ? -p.weight[3 * v + a] : p.weight[3 * v + a];
      }
    }
    part[c] = e;
  });
  double e = 0;
  for (double x : part) e += x;
  return e;
}

namespace ground {

void checkGrid(const GmrfProblem& p, std::size_t n, tbb::task_arena& arena) {
  std::vector<std::size_t> bad(kChunks, n);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
      for (std::size_t v = n * c / kChunks; v < n * (c + 1) / kChunks && bad[c] == n; ++v) {
        for (int a = 0; a < 3; ++a) {
          const std::uint32_t u = p.next[3 * v + a];
          if (u != GmrfProblem::kNone && (u >= n || p.prev[3 * u + a] != v || (p.parity[u] & 1) == (p.parity[v] & 1)))
            bad[c] = v;
          const std::uint32_t w = p.prev[3 * v + a];
          if (w != GmrfProblem::kNone && (w >= n || p.next[3 * w + a] != v)) bad[c] = v;
        }
      }
    });
  });
  for (std::size_t v : bad) {
    if (v != n)
      throw std::invalid_argument("GMRF problem: node " + std::to_string(v) +
                                  " is linked to a node that is missing, linked from another node along the same "
                                  "axis, not linked back, or of the same parity");
  }
}

IcmResult icm(const GmrfProblem& p, std::vector<std::uint8_t>& ground, int max_iterations, tbb::task_arena& arena) {
  const std::size_t n = ground.size();
  IcmResult result;
  if (max_iterations <= 0) {
    result.energy_initial = result.energy_final = gmrfEnergy(p, ground);
    return result;
  }
  // per chunk: energy summed in the first sweep, energy change, and the nodes that changed
  std::vector<double> energy(kChunks), delta(kChunks);
  std::vector<std::vector<std::uint32_t>> moved(kChunks);
  std::vector<std::uint32_t> visit;  // the nodes of the colour due next (after the first sweep)
  // the arrays, through pointers that each chunk copies into locals: the compiler then need not
  // read them again after every store of a label (a byte, which may alias anything)
  struct Arrays {
    const float *unary_ground, *unary_nonground, *weight;
    const std::uint32_t *next, *prev;
    const std::uint8_t* parity;
    std::uint8_t* ground;
  };
  const Arrays arrays{p.unary_ground.data(), p.unary_nonground.data(), p.weight.data(), p.next.data(),
                      p.prev.data(),         p.parity.data(),          ground.data()};
  // Updates node v of the given colour, in place; with `first`, adds the energy of the labelling
  // the sweep started from to e: the single-site term of every node, before its update, and each
  // pair once, from its node of colour 0.
  const auto update = [](const Arrays& q, std::uint32_t v, std::uint8_t colour, bool first, double& e, double& d,
                         std::vector<std::uint32_t>& changed) {
    // a neighbour's pair term for ground, -w if it is ground and w if not (a sign from its label,
    // without a branch); that for non-ground is its negative
    const auto term = [&](std::uint32_t u, float w) { return static_cast<double>(w) * (q.ground[u] ? -1.0 : 1.0); };
    double cost_g = q.unary_ground[v], cost_n = q.unary_nonground[v];
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t u = q.next[3 * v + a];
      if (u != GmrfProblem::kNone) {
        const double t = term(u, q.weight[3 * v + a]);
        cost_g += t, cost_n -= t;
      }
      const std::uint32_t b = q.prev[3 * v + a];
      if (b != GmrfProblem::kNone) {
        const double t = term(b, q.weight[3 * b + a]);
        cost_g += t, cost_n -= t;
      }
    }
    if (first)
      e += colour == 0 ? (q.ground[v] ? cost_g : cost_n) : (q.ground[v] ? q.unary_ground[v] : q.unary_nonground[v]);
    const std::uint8_t best = cost_g < cost_n ? 1 : (cost_n < cost_g ? 0 : q.ground[v]);
    if (best != q.ground[v]) {
      d += best ? cost_g - cost_n : cost_n - cost_g;
      q.ground[v] = best;
      changed.push_back(v);
    }
  };
  double change = 0;
  for (int sweep = 0; sweep < max_iterations; ++sweep) {
    bool any = false;
    for (std::uint8_t colour = 0; colour < 2; ++colour) {
      // nodes of one colour have no pair between them: update them all at once, in place
      arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, kChunks, [&](std::size_t c) {
          const Arrays q = arrays;
          std::vector<std::uint32_t>& changed = moved[c];
          double e = 0, d = 0;
          changed.clear();
          if (sweep == 0) {
            const std::size_t lo = n * c / kChunks, hi = n * (c + 1) / kChunks;
            for (std::size_t v = lo; v < hi; ++v) {
              if ((q.parity[v] & 1) == colour) update(q, static_cast<std::uint32_t>(v), colour, true, e, d, changed);
            }
          } else {
            const std::size_t m = visit.size(), lo = m * c / kChunks, hi = m * (c + 1) / kChunks;
            const std::uint32_t* const nodes = visit.data();
            for (std::size_t i = lo; i < hi; ++i) update(q, nodes[i], colour, false, e, d, changed);
          }
          if (sweep == 0) energy[c] += e;
          delta[c] = d;
        });
      });
      // the other colour's nodes next to those that changed are visited next
      visit.clear();
      for (std::size_t c = 0; c < kChunks; ++c) {
        change += delta[c];
        for (std::uint32_t v : moved[c]) {
          any = true;
          for (int a = 0; a < 3; ++a) {
            if (p.next[3 * v + a] != GmrfProblem::kNone) visit.push_back(p.next[3 * v + a]);
            if (p.prev[3 * v + a] != GmrfProblem::kNone) visit.push_back(p.prev[3 * v + a]);
          }
        }
      }
      std::sort(visit.begin(), visit.end());
      visit.erase(std::unique(visit.begin(), visit.end()), visit.end());
    }
    if (!any) break;
    ++result.sweeps;
  }
  for (double e : energy) result.energy_initial += e;
  result.energy_final = result.energy_initial + change;
  return result;
}

}  // namespace ground

IcmResult solveIcm(const GmrfProblem& p, std::vector<std::uint8_t>& ground, int max_iterations, int threads) {
  tbb::task_arena arena = ground::arenaFor(threads);
  ground::checkGrid(p, ground.size(), arena);
  return ground::icm(p, ground, max_iterations, arena);
}

}  // namespace terrain
