#pragma once
// BSwarm interaction force F_int (wang2015, section 4.1, eq. 4), exact and with a far-field approximation
// (docs/models/bswarm.md).
//
// For agent i and every other agent j at distance x = |r_j - r_i|:
//   zone rep: 0 <= x < rRep (g = -1), ali: rRep <= x < rAli (g = 0), att: rAli <= x <= rAtt (g = +1)
//   F_int,i = sum over zones k with N_k > 0 of  lambda_k / N_k * sum_{j in zone k} (g_k r^_ji + (1 - |g_k|) v^_ji)
// with r^_ji = unit(r_j - r_i), v^_ji = unit(v_j - v_i) (zero when the difference is zero) and N_k the number
// of neighbours in zone k (a neighbour at the agent's own position counts in zone rep).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "spatial/uniform_grid.hpp"

namespace swarmsim {

struct ZoneParams {
  float rRep = 0.2f, rAli = 0.2f, rAtt = 1.0f;  // absolute radii, m: 0 < rRep <= rAli <= rAtt
  float lambdaRep = 1.0f, lambdaAli = 0.0f, lambdaAtt = 1.0f;
  // from a model's (double) parameters: the three radii, then the three weights
  static ZoneParams of(double rRep, double rAli, double rAtt, double wRep, double wAli, double wAtt) {
    return {static_cast<float>(rRep), static_cast<float>(rAli),  static_cast<float>(rAtt),
            static_cast<float>(wRep), static_cast<float>(wAli), static_cast<float>(wAtt)};
  }
};

class InteractionForces {
 public:
  // theta = 0: exact (every neighbour). theta > 0: far neighbours approximated (larger = faster, less
  // accurate). The agents are grouped in a tree of boxes; a group of agents (a cell) acts on other agents as
  // one pseudo-agent (its count at its centroid, with its mean velocity) when the diagonal of its bounding
  // box is below theta times the smallest distance between it and the agents it acts on (for zone ali also
  // in velocity space) and every such pair lies in one zone. A cell below theta/2 times that distance (theta/8
  // if its agents do not fill its box evenly) that straddles a zone border is split between the zones by the
  // fraction of it inside. Agents near the zone borders of one another are always taken one by one.
  // docs/models/bswarm.md: details, measured error (default theta 2: p95 below about 3 %).
  // Inputs in the grid's sorted order k = 0..grid.size()-1: positions grid.sortedX()/Y()/Z(), velocities
  // vx/vy/vz[k]; any cell size works. Writes F_int to fx/fy/fz[k]. Deterministic: bit-identical for any
  // number of threads (and on any x86-64 CPU, with or without AVX). No heap allocation in steady state.
  void compute(const UniformGrid& grid, const float* vx, const float* vy, const float* vz, const ZoneParams& zones,
               float theta, float* fx, float* fy, float* fz);
  // seconds of the last compute (including any aggregation it builds)
  double seconds() const { return seconds_; }
  // what the far-field computation did, summed over its calls (the exact one counts nothing): agents
  // evaluated, the entries their scans ran over (agents one by one and pseudo-agents, each padded to whole
  // SIMD blocks), and the far-field terms they added (the expansion: one per agent; the cells split between
  // zones). Integers: the same for any number of threads. docs/performance.md turns them into flops.
  struct Work {
    std::uint64_t agents = 0, agentEntries = 0, pseudoEntries = 0, cuts = 0;
    Work& operator+=(const Work& o) {
      agents += o.agents;
      agentEntries += o.agentEntries;
      pseudoEntries += o.pseudoEntries;
      cuts += o.cuts;
      return *this;
    }
  };
  const Work& work() const { return work_; }

  // Implementation types (public for the helpers in the source file).
  // candidates of one query as structure of arrays (w: agents per entry), padded to whole SIMD blocks
  struct Block {
    std::vector<float> x, y, z, vx, vy, vz, w;
    std::size_t size = 0;
  };
  // a cell of the tree: its agents are [begin, end) in Morton order
  struct alignas(64) Node {
    // what the walk reads first: in the first 64 bytes
    std::uint32_t begin, end, firstChild, childCount;  // childCount 0: a leaf
    float lo[3], hi[3];                                // bounding box of the agents
    float diag2;                                       // squared diagonal of the box
    float c[3];                                        // centroid
    float v[3];                                        // mean velocity
    float vlo[3], vhi[3];                              // bounding box of the velocities
    float vdiag2;                                      // its squared diagonal
    float cov[6];                                      // covariance of the positions: xx, xy, xz, yy, yz, zz
  };
  // the far field of a group of agents, to first order about its centroid (position) and mean velocity:
  // zone k (0 rep, 1 ali, 2 att) adds s[k] + g[k] (x - centre) to the sum of unit vectors, n[k] to N_k
  struct Expansion {
    double s[3][3], g[3][9], n[3];
    double c[3], v[3];
  };
  // how a cell cut by zone borders spreads toward a batch (addCut)
  struct CutModel {
    float w[3];     // widths of three uniform distributions; all 0: the agents coincide
    float lateral;  // mean squared distance of the agents from the line through the centroid
  };
  struct alignas(64) Scratch {                                 // one per thread: aligned against false sharing
    Block list;                                                // the agents near one batch
    Block far;                                                 // pseudo-agents for the batch and its ancestors
    std::vector<std::uint32_t> cand, open, near, cut, leaves;  // the tree walk (see walk)
    std::vector<Expansion> exp;                                // one per tree level of the walk
    std::vector<CutModel> cutModels;                           // per cut cell: its model for the batch
    Work work;                                                 // this thread's share of the last compute
  };

 private:
  void computeExact(const UniformGrid& grid, const float* vx, const float* vy, const float* vz, const ZoneParams& zones,
                    float* fx, float* fy, float* fz);
  void computeApprox(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                     const ZoneParams& zones, float theta, float* fx, float* fy, float* fz);
  void buildTree(const UniformGrid& grid, const float* vx, const float* vy, const float* vz);
  template <typename Walk>
  void walk(std::uint32_t t, std::size_t candBegin, std::size_t candEnd, std::size_t level, Scratch& sc,
            const Walk& w) const;
  template <typename Walk>
  void evaluateBatch(const Node& t, const Expansion& e, Scratch& sc, const Walk& w) const;

  double seconds_ = 0.0;
  Work work_;
  std::vector<Scratch> scratch_;  // one per thread
  Block all_;                     // every agent in one block (when rAtt covers the whole swarm)
  // the tree: agents in Morton order (positions, velocities, sorted position k), nodes level by level
  std::vector<float> mx_, my_, mz_, mvx_, mvy_, mvz_;
  std::vector<std::uint32_t> code_, mk_, tmpCode_, tmpK_, bucket_;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> depth_, parent_, split_;  // per node
  std::vector<std::uint32_t> levelStart_;              // first node of each level
  std::vector<std::uint32_t> tasks_;                   // subtrees walked in parallel
  std::vector<float> boxPart_;                         // per-chunk bounding boxes
  std::vector<double> sums_;  // per node: sums of positions, velocities, position products (build scratch)
};

// relative error of approximate vs exact forces: for a subset (every `stride`-th agent),
// |F_approx - F_exact| / |F_exact| (agents with |F_exact| tiny skipped); returns {median, p95}.
// For reports and tests.
struct ForceError {
  double median = 0.0, p95 = 0.0;
  std::size_t samples = 0;
};
ForceError approximationError(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                              const ZoneParams& zones, float theta, std::size_t stride);

}  // namespace swarmsim
