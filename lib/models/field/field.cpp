#include "models/field/field.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "fields/curl_noise.hpp"
#include "fields/fast_marching.hpp"
#include "fields/grid3.hpp"
#include "fields/sample_batch.hpp"
#include "geometry/clearance.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/field/mde.hpp"
#include "models/params_util.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace {

inline float bitsAsFloat(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

#if SWARMSIM_X86_LANES
// Phase 1 where each velocity is the combined field's sample v (padded with a 0): the m agents' records, 32 bytes
// each (the tentative position x + v dt, the id's bits, v and 0), streamed to `rec`, and the tentative positions
// to tx, ty and tz. The scalar code's operations, lane by lane
SWARMSIM_AVX void recordsAvx(const float* px, const float* py, const float* pz, const std::uint32_t* id,
                             const PaddedVec3* v, std::size_t m, float dt, float* rec, float* tx, float* ty,
                             float* tz) {
  const __m128 dt4 = _mm_set1_ps(dt);
  for (std::size_t q = 0; q < m; ++q) {
    const __m128 vel = _mm_load_ps(v[q].v);
    const __m128 t = _mm_add_ps(_mm_setr_ps(px[q], py[q], pz[q], 0.0f), _mm_mul_ps(vel, dt4));
    const __m128 idBits = _mm_castsi128_ps(_mm_cvtsi32_si128(static_cast<int>(id[q])));
    _mm_stream_ps(rec + 8 * q, _mm_insert_ps(t, idBits, 0x30));
    _mm_stream_ps(rec + 8 * q + 4, vel);
    _mm_store_ss(tx + q, t);
    _mm_store_ss(ty + q, _mm_movehdup_ps(t));
    _mm_store_ss(tz + q, _mm_movehl_ps(t, t));
  }
}
#endif

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string dimsText(const std::array<int, 3>& n) {
  return std::to_string(n[0]) + "x" + std::to_string(n[1]) + "x" + std::to_string(n[2]);
}

GoalSpec readGoal(JsonReader g) {
  GoalSpec goal;
  const std::string type = g.choice("type", "", {"sphere", "box"});
  if (type.empty()) g.failMissing("type", "\"sphere\" or \"box\"");
  // keyframes first: with them, the goal's own centre is optional (the first key's)
  readKeyframes(g, goal.keyTimes, goal.keyCenters);
  if (type == "sphere") {
    goal.kind = GoalSpec::Kind::kSphere;
    goal.center = goal.keyCenters.empty() ? g.requireVec3("center", Range::coordinate())
                                          : g.vec3("center", goal.keyCenters.front(), Range::coordinate());
    goal.radius = g.requireNumber("radius", Range::length());
  } else {
    goal.kind = GoalSpec::Kind::kBox;
    const Vec3d lo = g.requireVec3("min", Range::coordinate()), hi = g.requireVec3("max", Range::coordinate());
    for (int a = 0; a < 3; ++a) {
      if (!(hi[a] > lo[a])) g.fail("max", std::string("expected max > min on every axis (axis ") + "xyz"[a] + ")");
    }
    goal.center = 0.5 * (lo + hi);
    goal.halfSize = 0.5 * (hi - lo);
  }
  g.finish();
  return goal;
}

class FieldConfig final : public ModelConfig {
 public:
  explicit FieldConfig(const FieldParams& p) : p_(p) {}
  std::unique_ptr<Model> build(const World& world) const override { return makeField(p_, world); }

 private:
  FieldParams p_;
};

class FieldModel final : public Model {
 public:
  FieldModel(const FieldParams& p, const World& world) : p_(p), domain_(world.domain) {
    costSpec_ = GridSpec::covering(world.domain.min, world.domain.max, p.costCells);
    noiseSpec_ = GridSpec::covering(world.domain.min, world.domain.max, p.noiseCells);
    const Obstacles& obs = *world.obstacles;

    // distances (eq. 5): at the cost grid, and at the noise grid where the curl
    // noise's boundary blend or the obstacle clearance (finer grid) needs them
    auto t0 = Clock::now();
    const bool noiseFiner = noiseSpec_.cell.minCoeff() < costSpec_.cell.minCoeff();
    Grid3<float> sdfCost = signedDistance(obs, costSpec_);
    Grid3<float> sdfNoise;
    if (p_.noise == NoiseKind::kCurl || noiseFiner) sdfNoise = signedDistance(obs, noiseSpec_);
    tDistance_ = since(t0);

    // cost: per-cell |∇C| = A + B g (eq. 7 as we read it), obstacles impassable, then fast marching
    t0 = Clock::now();
    const double diag = costSpec_.cell.norm();  // a: the cell diagonal (3-D)
    fmmIn_.spec = costSpec_;
    fmmIn_.order = p_.costOrder;
    fmmIn_.cost.resize(costSpec_.size());
    parallelFor(fmmIn_.cost.size(), [&](std::size_t c) {
      const float phi = sdfCost.data[c];
      fmmIn_.cost[c] = phi < 0.0f ? std::numeric_limits<float>::infinity()
                                  : static_cast<float>(p_.pathWeight + p_.repulsionWeight * bell(phi / (2.0 * diag)));
    });
    solveCost(0.0);
    tCost_ = since(t0);
    tFmm_ = lastFmmSeconds_;

    // noise: potential blended toward the boundaries (obstacles and domain walls), its curl
    t0 = Clock::now();
    if (p_.noise != NoiseKind::kWhite) {
      NoiseParams np;
      np.scale = p_.scale;
      np.gain = p_.gain;
      np.seeds = p_.seeds;
      np.unit = costSpec_.cell.minCoeff();
      np.d0 = p_.rampDistance;
      if (p_.noise == NoiseKind::kCurl) {
        // boundary distance: obstacles and the domain's walls
        Grid3<float> boundary = sdfNoise;
        addBoxWalls(boundary, domain_);
        noise_ = curl(noisePotential(noiseSpec_, np, &boundary));
      } else {
        noise_ = perlinVelocity(noiseSpec_, np);
      }
    }
    tNoise_ = since(t0);

    combine();

    // obstacle clearance uses the finer of the two distance grids
    clearance_ = ObstacleClearance(noiseFiner ? std::move(sdfNoise) : std::move(sdfCost),
                                   static_cast<float>(p_.agentRadius), !obs.empty());
  }

  std::vector<std::string> statNames() const override { return {"mde_fraction", "cost_solves"}; }

  void takeFrameStats(std::vector<double>& values) override {
    values = {frameAgentSteps_ > 0 ? static_cast<double>(frameMoved_) / static_cast<double>(frameAgentSteps_) : 0.0,
              static_cast<double>(frameSolves_)};
    frameMoved_ = frameAgentSteps_ = 0;
    frameSolves_ = 0;
  }

  // carried between steps: the goal positions the cost field was last solved
  // for (a moving goal re-solves only after moving half a cell, so the field in
  // use depends on the history) and the statistics counters
  void saveState(StateOut& out) const override {
    std::vector<double> c;
    for (const Vec3d& v : solvedCenters_) c.insert(c.end(), {v.x(), v.y(), v.z()});
    out.putVector(c);
    for (std::size_t v : {frameMoved_, frameAgentSteps_, totalMoved_, totalAgentSteps_}) out.put<std::uint64_t>(v);
    out.put<std::int64_t>(frameSolves_);
    out.put<std::int64_t>(solves_);
  }

  void loadState(StateIn& in, const World&) override {
    const std::vector<double> c = in.getVector<double>();
    if (c.size() != 3 * p_.goals.size()) throw std::runtime_error("field checkpoint: goal count differs");
    std::vector<Vec3d> centers;
    for (std::size_t g = 0; g < p_.goals.size(); ++g) centers.emplace_back(c[3 * g], c[3 * g + 1], c[3 * g + 2]);
    for (std::size_t* v : {&frameMoved_, &frameAgentSteps_, &totalMoved_, &totalAgentSteps_}) {
      *v = static_cast<std::size_t>(in.get<std::uint64_t>());
    }
    frameSolves_ = in.get<std::int64_t>();
    const long long solves = in.get<std::int64_t>();
    if (centers != solvedCenters_) {
      solveAt(centers);
      combine();
    }
    solves_ = solves;
  }

  Json benchInfo() const override {
    const char* noise = p_.noise == NoiseKind::kCurl ? "curl" : p_.noise == NoiseKind::kPerlin ? "perlin" : "white";
    return {
        {"noise", noise},
        {"scale", p_.scale},
        {"gain", p_.gain},
        {"s0", p_.speed},
        {"cost_grid", dimsText(costSpec_.n)},
        {"noise_grid", dimsText(noiseSpec_.n)},
        {"t_distance", tDistance_},
        {"t_cost", tCost_},
        {"t_fast_marching", tFmm_},
        {"t_noise", tNoise_},
        {"mde_percent",
         totalAgentSteps_ > 0 ? 100.0 * static_cast<double>(totalMoved_) / static_cast<double>(totalAgentSteps_) : 0.0},
        {"cost_solves", solves_},
        {"cost_solve_seconds", totalSolveSeconds_}};
  }

  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    const std::size_t n = s.size();
    const double t = info.time;
    // a moving goal: re-solve the cost field once it has moved half a cell
    if (dynamicGoals_) {
      const double threshold = 0.5 * costSpec_.cell.minCoeff();
      bool moved = false;
      for (std::size_t g = 0; g < p_.goals.size(); ++g) {
        moved = moved || (p_.goals[g].centerAt(t) - solvedCenters_[g]).norm() > threshold;
      }
      if (moved) {
        const auto t0 = Clock::now();
        solveCost(t);
        combine();
        totalSolveSeconds_ += since(t0);
        ++frameSolves_;
      }
    }

    // phase 1: velocities from the fields, tentative positions. For MDE, each agent's tentative position goes
    // into the arrays that "neighbours" builds its grid from, or, for "same_cell", its bin is found here: the
    // bins are the cost grid's cells (binsFor)
    const bool mde = p_.minDistance > 0.0 && n > 1;
    const bool sameCell = mde && p_.mdePairs == MdePairs::kSameCell;
    if (mde && !sameCell) {
      for (auto* a : {&nx_, &ny_, &nz_}) a->resize(n);
    }
    if (sameCell && boxStep_ != info.step) findBox(s);
    const Bins bins = sameCell ? binsFor(n, boxLo_.data(), boxHi_.data()) : Bins{};
    boxStep_ = kNoBox;
    if (sameCell) bin_.resize(n);
    std::uint32_t* const binOf = bin_.data();
    std::atomic<bool> nonFinite{false};
    carried_.resize(n);
    const float dt = static_cast<float>(world.dt);
    const Vec3 light = p_.light.cast<float>();
    const float gain = static_cast<float>(p_.gain);
    const auto combined = combined_.sampler(), global = global_.sampler(), noise = noise_.sampler();
    const LaneSet lanes = laneSet();
    // (each velocity is the combined field's sample, and AVX is there: the records built in registers)
    const bool direct = combinedOk_ && !p_.phototaxis && lanes != LaneSet::kSse;
    // agent i's velocity into its record; returns its tentative position
    const auto agent = [&](std::size_t i, const Vec3& fieldV) {
      const Vec3 x = s.position(i);
      Vec3 v;
      if (combinedOk_) {
        v = fieldV;  // V = ∇×N + V_g (eq. 9), one lookup
      } else {
        v = hasGoals_ ? global(x) : Vec3::Zero();
        if (p_.noise == NoiseKind::kWhite) {
          AgentRng rng(world.seed, info.step, s.id[i], RngPurpose::kNoise, info.swarmIndex);
          v += rng.normal3() * gain;
        } else {
          v += noise(x);
        }
      }
      if (p_.phototaxis) {
        AgentRng rng(world.seed, info.step, s.id[i], RngPurpose::kPhototaxis, info.swarmIndex);
        if (rng.uniform() < static_cast<float>(p_.phototaxisProbability)) {
          v += normalizedOrZero(light - x) * static_cast<float>(p_.phototaxisSpeed);
        }
      }
      const float tx = x.x() + v.x() * dt, ty = x.y() + v.y() * dt, tz = x.z() + v.z() * dt;
#if defined(__SSE2__)
      {
        // streaming stores: the records go to memory without first reading the lines they fill (a million
        // records do not stay in the caches until the group pass reads them)
        float* rec = reinterpret_cast<float*>(carried_.data() + i);
        _mm_stream_ps(rec, _mm_setr_ps(tx, ty, tz, bitsAsFloat(s.id[i])));
        _mm_stream_ps(rec + 4, _mm_setr_ps(v.x(), v.y(), v.z(), 0.0f));
      }
#else
      carried_[i] = Carried{tx, ty, tz, s.id[i], v.x(), v.y(), v.z(), 0.0f};
#endif
      return Vec3(tx, ty, tz);
    };
    // each thread's agents, then what is left of the other's, in pieces of 8192 (each agent's result is its own,
    // so how the pieces are shared does not matter; a thread on a slower CPU, or one busy elsewhere, no longer
    // holds the other at the end), and in blocks: the combined field's samples of a block first, eight at a time
    parallelForBalancedChunks(n, 8192, [&](std::size_t first, std::size_t last) {
      constexpr std::size_t kBlock = 64;
      PaddedVec3 fieldV[kBlock];
      float tx[kBlock], ty[kBlock], tz[kBlock];
      for (std::size_t b = first; b < last; b += kBlock) {
        const std::size_t m = std::min(kBlock, last - b);
        const float *const px = s.px.data() + b, *const py = s.py.data() + b, *const pz = s.pz.data() + b;
#if SWARMSIM_X86_LANES
        if (direct) {
          sampleBatch(combined, px, py, pz, m, fieldV, lanes);
          recordsAvx(px, py, pz, s.id.data() + b, fieldV, m, dt, reinterpret_cast<float*>(carried_.data() + b), tx, ty,
                     tz);
        } else
#endif
        {
          if (combinedOk_) sampleBatch(combined, px, py, pz, m, fieldV, lanes);
          for (std::size_t q = 0; q < m; ++q) {
            const float* const v = fieldV[q].v;
            const Vec3 tent = agent(b + q, combinedOk_ ? Vec3(v[0], v[1], v[2]) : Vec3::Zero());
            tx[q] = tent.x();
            ty[q] = tent.y();
            tz[q] = tent.z();
          }
        }
        if (sameCell) {
          if (!bins.ofBlock(tx, ty, tz, m, binOf + b)) nonFinite.store(true, std::memory_order_relaxed);
        } else if (mde) {
          std::copy(tx, tx + m, nx_.data() + b);
          std::copy(ty, ty + m, ny_.data() + b);
          std::copy(tz, tz + m, nz_.data() + b);
        }
      }
#if defined(__SSE2__)
      _mm_sfence();  // (the streamed records visible to every thread before the next loop)
#endif
    });
    if (nonFinite.load()) throw std::runtime_error("field: a non-finite agent position");

    // keep clear of obstacles and inside the domain (applied to each final position)
    const Vec3 lo = domain_.min.cast<float>(), hi = domain_.max.cast<float>();
    // phase 2: minimum distance enforcement on the tentative positions, then
    // clearance; the state is rewritten in grid order (spatial sorting)
    next_.resizeStorage(n);
    // (the next state's arrays as locals: stores through them cannot change them, so the loops need not load
    // them again after each store)
    float *const nextPx = next_.px.data(), *const nextPy = next_.py.data(), *const nextPz = next_.pz.data();
    float *const nextVx = next_.vx.data(), *const nextVy = next_.vy.data(), *const nextVz = next_.vz.data();
    std::uint32_t* const nextId = next_.id.data();
    const ObstacleClearance& clearance = clearance_;
    // an agent's id and velocity, unchanged from phase 1, at its place k in the next state
    const auto carry = [&](std::size_t k, const Carried& r) {
      nextId[k] = r.id;
      nextVx[k] = r.vx;
      nextVy[k] = r.vy;
      nextVz[k] = r.vz;
    };
    std::size_t moved = 0;
    if (mde) {
      const float md = static_cast<float>(p_.minDistance);
      // "neighbours": every pair closer than d_min, found in cells of 2 d_min (an
      // agent's ball overlaps at most 2 cells per axis). "same_cell": the paper's
      // rule, only pairs sharing a cell of the cost grid (binsFor).
      if (sameCell) {
        // (the sorted positions are read from the agents' records, a group of bins at a time)
        grid_.buildFromCells(bin_, n, bins.dims, bins.origin, bins.edge);
      } else {
        grid_.build(nx_.data(), ny_.data(), nz_.data(), n, 2.0f * md, 8.0, true);
      }
      const auto& order = grid_.order();
      movedFlag_.resize(n);
      if (sameCell) {
        // each pair once, bin by bin: a bin's pairs move only its own agents. The bins in groups of 64: each
        // group's agents gathered from their records into the thread's scratch (in grid order, with room for
        // the kernel's loads past a bin's end), their pairs pushed bin by bin, then settled together
        // (clearance and the domain, eight at a time)
        const std::size_t cells = grid_.cellCount();
        std::uint8_t* const movedFlag = movedFlag_.data();
        const Carried* const carried = carried_.data();
        groupScratch_.resize(static_cast<std::size_t>(threadCount()));
        constexpr std::size_t kGroup = 64;
        const std::size_t groups = (cells + kGroup - 1) / kGroup;
        const auto groupWork = [&](std::size_t g) {
          const std::size_t c0 = g * kGroup, c1 = std::min(cells, c0 + kGroup);
          const std::uint32_t first = grid_.cellBegin(c0), last = grid_.cellEnd(c1 - 1);
          if (first == last) return;
          GroupScratch& w = groupScratch_[static_cast<std::size_t>(threadIndex())];
          const std::size_t m = last - first;
          w.reserve(m + 8);
          float *const gx = w.x.data(), *const gy = w.y.data(), *const gz = w.z.data();
          float *const pushX = w.px.data(), *const pushY = w.py.data(), *const pushZ = w.pz.data();
          std::int32_t* const hits = w.hits.data();
          for (std::uint32_t k = first; k < last; ++k) {
            // (the records of the agents a few bins on: a new bin's agents come from several bins of the last
            // step's order, streams too many for the hardware's prefetch)
            if (k + kCarriedAhead < n) __builtin_prefetch(carried + order[k + kCarriedAhead]);
            const Carried& r = carried[order[k]];
            const std::size_t q = k - first;
            gx[q] = r.x;
            gy[q] = r.y;
            gz[q] = r.z;
            carry(k, r);
          }
          for (std::size_t c = c0; c < c1; ++c) {
            const std::uint32_t b = grid_.cellBegin(c) - first, e = grid_.cellEnd(c) - first;
            if (b == e) continue;
            if (mdeCellPairs(gx, gy, gz, b, e, md, pushX, pushY, pushZ, hits, lanes)) {
              // exactly coincident agents (rare) separate along x, ordered by id
              for (std::uint32_t k = b; k < e; ++k) {
                for (std::uint32_t j = k + 1; j < e; ++j) {
                  if (gx[j] != gx[k] || gy[j] != gy[k] || gz[j] != gz[k]) continue;
                  const float f = (nextId[first + k] < nextId[first + j] ? 0.5f : -0.5f) * md;
                  pushX[k] -= f;
                  pushX[j] += f;
                  ++hits[k];
                  ++hits[j];
                }
              }
            }
          }
          for (std::uint32_t k = first; k < last; ++k) {
            const std::size_t q = k - first;
            movedFlag[k] = hits[q] > 0 ? 1 : 0;
            nextPx[k] = gx[q] + pushX[q];
            nextPy[k] = gy[q] + pushY[q];
            nextPz[k] = gz[q] + pushZ[q];
          }
          clearance.settle(nextPx + first, nextPy + first, nextPz + first, m, lo, hi, lanes);
          // the next step's box (min and max are exact: any order of groups gives the same)
          growBox(nextPx + first, nextPy + first, nextPz + first, m,
                  threadBoxes_[static_cast<std::size_t>(threadIndex())], lanes);
        };
        threadBoxes_.assign(static_cast<std::size_t>(threadCount()), kEmptyBox);
        if (n < kSerialBelow) {  // few agents: not worth waking the team
          for (std::size_t g = 0; g < groups; ++g) groupWork(g);
        } else {
          parallelForDynamic(groups,
                             std::clamp<std::size_t>(groups / (32 * static_cast<std::size_t>(threadCount())), 1, 4),
                             groupWork);
        }
        boxFrom(threadBoxes_);
        boxStep_ = info.step + 1;
      } else {
        const float* sx = grid_.sortedX().data();
        const float* sy = grid_.sortedY().data();
        const float* sz = grid_.sortedZ().data();
        // each thread's range of agents, then their settling (clearance and the domain) together
        parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
          for (std::size_t k = first; k < last; ++k) {
            const std::uint32_t i = order[k];
            MdePush kernel(md);
            kernel.start(sx[k], sy[k], sz[k]);
            grid_.forEachRun(sx[k], sy[k], sz[k], md,
                             [&](std::uint32_t b, std::uint32_t e) { kernel.add(sx, sy, sz, b, e); });
            Vec3 push = kernel.push();
            bool pushed = kernel.hits() > 0;
            if (kernel.zeros() > 1) {
              // an exactly coincident neighbour (rare): coincident agents separate
              // along x, ordered by id, on top of the kernel's other pushes
              const auto fromCoincident = [&](std::uint32_t j, float dx, float dy, float dz) {
                if (j == k || dx != 0.0f || dy != 0.0f || dz != 0.0f) return;
                push.x() += (s.id[i] < s.id[order[j]] ? -0.5f : 0.5f) * md;
                pushed = true;
              };
              grid_.forEachNeighbor(
                  sx[k], sy[k], sz[k], 0.0f,
                  [&](std::uint32_t j, float dx, float dy, float dz, float) { fromCoincident(j, dx, dy, dz); });
            }
            movedFlag_[k] = pushed ? 1 : 0;
            carry(k, carried_[i]);
            nextPx[k] = sx[k] + push.x();
            nextPy[k] = sy[k] + push.y();
            nextPz[k] = sz[k] + push.z();
          }
          clearance.settle(nextPx + first, nextPy + first, nextPz + first, last - first, lo, hi, lanes);
        });
      }
      std::vector<std::size_t>& counts = movedCounts_;
      counts.assign(static_cast<std::size_t>(chunkCount(n)), 0);
      parallelChunks(n, [&](std::size_t first, std::size_t last, int chunk) {
        std::size_t c = 0;
        for (std::size_t k = first; k < last; ++k) c += movedFlag_[k];
        counts[static_cast<std::size_t>(chunk)] = c;
      });
      for (const std::size_t c : counts) moved += c;
    } else {
      parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
        for (std::size_t i = first; i < last; ++i) {
          const Carried& r = carried_[i];
          carry(i, r);
          nextPx[i] = r.x;
          nextPy[i] = r.y;
          nextPz[i] = r.z;
        }
        clearance.settle(nextPx + first, nextPy + first, nextPz + first, last - first, lo, hi, lanes);
      });
    }

    s.swapStorage(next_);

    frameMoved_ += moved;
    totalMoved_ += moved;
    frameAgentSteps_ += n;
    totalAgentSteps_ += n;
  }

 private:
  // V = noise + V_g on the noise grid (V_g sampled there), so a step does one lookup
  void combine() {
    combinedOk_ = p_.noise != NoiseKind::kWhite && noiseSpec_.cell.maxCoeff() <= costSpec_.cell.minCoeff();
    if (!combinedOk_) return;  // a coarser noise grid would blur V_g: two lookups then
    combined_ = noise_;
    if (!hasGoals_) return;
    parallelFor(combined_.data.size(), [&](std::size_t c) {
      combined_.data[c] += global_.sample(combined_.spec.centerOfIndex(c).cast<float>());
    });
  }

  void solveCost(double t) {
    std::vector<Vec3d> centers;
    for (const auto& g : p_.goals) centers.push_back(g.centerAt(t));
    solveAt(centers);
  }

  // the cost field for goals centred at `centers` (one per goal)
  void solveAt(const std::vector<Vec3d>& centers) {
    solvedCenters_ = centers;
    hasGoals_ = !p_.goals.empty();
    dynamicGoals_ = false;
    for (const auto& g : p_.goals) dynamicGoals_ = dynamicGoals_ || !g.keyTimes.empty();
    if (!hasGoals_) return;
    FastMarchingInput& in = fmmIn_;  // cost per cell set once; goals per solve
    in.goal.assign(costSpec_.size(), 0);
    for (std::size_t g = 0; g < p_.goals.size(); ++g) {
      bool any = false;
      const Vec3d c = solvedCenters_[g];
      for (int k = 0; k < costSpec_.n[2]; ++k) {
        for (int j = 0; j < costSpec_.n[1]; ++j) {
          for (int i = 0; i < costSpec_.n[0]; ++i) {
            if (p_.goals[g].contains(costSpec_.center(i, j, k), c)) {
              in.goal[costSpec_.index(i, j, k)] = 1;
              any = true;
            }
          }
        }
      }
      if (!any) {  // a goal smaller than a cell: the cell holding its centre
        const auto cc = costSpec_.cellOf(c);
        in.goal[costSpec_.index(cc[0], cc[1], cc[2])] = 1;
      }
    }
    const auto t0 = Clock::now();
    Grid3<float> cost = fastMarching(in);
    lastFmmSeconds_ = since(t0);
    global_ = descentDirection(cost, static_cast<float>(p_.speed));
    ++solves_;
  }

  FieldParams p_;
  Aabb domain_;
  GridSpec costSpec_, noiseSpec_;
  ObstacleClearance clearance_;  // on the finer of the two distance grids
  FastMarchingInput fmmIn_;             // |∇C| per cost cell (inf inside obstacles) and the goal cells
  Grid3<Vec3> global_;                  // V_g (eq. 8)
  Grid3<Vec3> noise_;                   // ∇×N (eq. 1), or plain Perlin for the baseline
  Grid3<Vec3> combined_;                // noise_ + V_g on the noise grid (eq. 9)
  bool hasGoals_ = false, dynamicGoals_ = false, combinedOk_ = false;
  std::vector<Vec3d> solvedCenters_;
  double tDistance_ = 0.0, tCost_ = 0.0, tNoise_ = 0.0, tFmm_ = 0.0, lastFmmSeconds_ = 0.0;
  // statistics
  std::size_t frameMoved_ = 0, frameAgentSteps_ = 0, totalMoved_ = 0, totalAgentSteps_ = 0;
  double totalSolveSeconds_ = 0.0;
  long long frameSolves_ = 0, solves_ = 0;
  // same_cell's bins: the cost grid's cells over the swarm's box (the cells its agents are in at the start of the
  // step, one more on each side); with fewer than one agent per 8 of those cells, aligned blocks of f x f x f
  // of them (so that a step's counting sort over the bins stays linear in the agents). of(p) is the bin
  // holding p, clamped to the box (an agent that moved more than a cell out of it joins a bin at its edge).
  struct Bins {
    int dims[3] = {1, 1, 1};
    double origin[3] = {0, 0, 0}, edge[3] = {1, 1, 1};
    float o[3] = {0, 0, 0}, inv[3] = {1, 1, 1}, top[3] = {0, 0, 0};
    std::uint32_t of(float x, float y, float z) const {
      const auto axis = [&](float v, int a) {
        const float t = (v - o[a]) * inv[a];
        return static_cast<int>(std::min(std::max(0.0f, t), top[a]));  // (NaN: 0)
      };
      return static_cast<std::uint32_t>((axis(z, 2) * dims[1] + axis(y, 1)) * dims[0] + axis(x, 0));
    }
    // of() for m points, four at a time where SSE2 is there (the same operations: max(t, 0) gives its second
    // operand, 0, for NaN, as std::max(0.0f, t) does); false if a point is not finite (x - x is 0 for every
    // finite x, NaN for an infinity or NaN)
    bool ofBlock(const float* x, const float* y, const float* z, std::size_t m, std::uint32_t* out) const {
      std::size_t q = 0;
      bool finite = true;
#if defined(__SSE2__)
      alignas(16) std::int32_t cell[3][4];
      __m128 bad = _mm_setzero_ps();
      for (; q + 4 <= m; q += 4) {
        const float* v[3] = {x + q, y + q, z + q};
        __m128 sum = _mm_setzero_ps();
        for (int a = 0; a < 3; ++a) {
          const __m128 p = _mm_loadu_ps(v[a]);
          sum = _mm_add_ps(sum, p);
          const __m128 t = _mm_mul_ps(_mm_sub_ps(p, _mm_set1_ps(o[a])), _mm_set1_ps(inv[a]));
          const __m128 c = _mm_min_ps(_mm_max_ps(t, _mm_setzero_ps()), _mm_set1_ps(top[a]));
          _mm_store_si128(reinterpret_cast<__m128i*>(cell[a]), _mm_cvttps_epi32(c));
        }
        const __m128 d = _mm_sub_ps(sum, sum);
        bad = _mm_or_ps(bad, _mm_cmpunord_ps(d, d));
        for (int l = 0; l < 4; ++l) {
          out[q + static_cast<std::size_t>(l)] =
              static_cast<std::uint32_t>((cell[2][l] * dims[1] + cell[1][l]) * dims[0] + cell[0][l]);
        }
      }
      finite = _mm_movemask_ps(bad) == 0;
#endif
      for (; q < m; ++q) {
        out[q] = of(x[q], y[q], z[q]);
        const float sum = x[q] + y[q] + z[q];
        finite = finite && sum - sum == 0.0f;
      }
      return finite;
    }
  };
  // the bins for n agents in the box [lo, hi]
  Bins binsFor(std::size_t n, const float lo[3], const float hi[3]) const {
    const auto low = costSpec_.cellOf(Vec3d(lo[0], lo[1], lo[2])), high = costSpec_.cellOf(Vec3d(hi[0], hi[1], hi[2]));
    int c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
      const std::size_t u = static_cast<std::size_t>(a);
      c0[a] = std::max(0, low[u] - 1);
      c1[a] = std::max(c0[a], std::min(costSpec_.n[u] - 1, high[u] + 1));  // (a box of NaNs: one cell)
    }
    const double most = 8.0 * static_cast<double>(n) + 64.0;
    Bins b;
    for (int f = 1;; ++f) {
      double count = 1.0;
      for (int a = 0; a < 3; ++a) {
        const int first = c0[a] / f * f;  // blocks aligned on the cost grid
        b.dims[a] = (c1[a] - first) / f + 1;
        b.origin[a] = costSpec_.min[a] + first * costSpec_.cell[a];
        b.edge[a] = costSpec_.cell[a] * f;
        count *= b.dims[a];
      }
      if (count <= most) break;
    }
    for (int a = 0; a < 3; ++a) {
      b.o[a] = static_cast<float>(b.origin[a]);
      b.inv[a] = static_cast<float>(1.0 / b.edge[a]);
      b.top[a] = static_cast<float>(b.dims[a] - 1);
    }
    return b;
  }
  // the box of the agents' positions at the start of step boxStep_ (kNoBox: none): same_cell's group pass
  // finds it for the next step from the positions it writes
  static constexpr std::uint64_t kNoBox = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t boxStep_ = kNoBox;
  std::array<float, 3> boxLo_{}, boxHi_{};
  std::vector<std::array<float, 6>> threadBoxes_;
  static constexpr float kBig = std::numeric_limits<float>::max();
  static constexpr std::array<float, 6> kEmptyBox = {kBig, kBig, kBig, -kBig, -kBig, -kBig};
  void boxFrom(const std::vector<std::array<float, 6>>& parts) {
    boxLo_ = {kBig, kBig, kBig};
    boxHi_ = {-kBig, -kBig, -kBig};
    for (const auto& p : parts) {
      for (std::size_t a = 0; a < 3; ++a) {
        boxLo_[a] = std::min(boxLo_[a], p[a]);
        boxHi_[a] = std::max(boxHi_[a], p[3 + a]);
      }
    }
  }
  // the box of the state's positions (a step that follows none of ours: the first, or one after a resume)
  void findBox(const SwarmState& s) {
    threadBoxes_.assign(static_cast<std::size_t>(chunkCount(s.size())), kEmptyBox);
    parallelChunks(s.size(), [&](std::size_t first, std::size_t last, int t) {
      growBox(s.px.data() + first, s.py.data() + first, s.pz.data() + first, last - first,
              threadBoxes_[static_cast<std::size_t>(t)], laneSet());
    });
    boxFrom(threadBoxes_);
  }

  // scratch, reused every step
  UniformGrid grid_;
  std::vector<float> nx_, ny_, nz_;  // "neighbours": the tentative positions its grid is built from
  std::vector<std::uint32_t> bin_;   // "same_cell": each agent's bin (swapped with the grid's buffer)
  // what an agent carries from phase 1 into the state in grid order: its tentative position, id and velocity in
  // one 32-byte record, so that same_cell's gather in grid order reads half a cache line per agent (its grid
  // keeps no sorted copies of the positions).
  struct alignas(32) Carried {
    float x, y, z;  // the tentative position
    std::uint32_t id;
    float vx, vy, vz, unused;
  };
  std::vector<Carried> carried_;
  static constexpr std::size_t kCarriedAhead = 128;
  std::vector<std::uint8_t> movedFlag_;
  // same_cell MDE, per thread: a group of bins' sorted positions and their pushes (grown, never shrunk)
  struct GroupScratch {
    std::vector<float> x, y, z, px, py, pz;
    std::vector<std::int32_t> hits;
    void reserve(std::size_t size) {
      if (x.size() >= size) return;
      for (auto* a : {&x, &y, &z, &px, &py, &pz}) a->resize(size);
      hits.resize(size);
    }
  };
  std::vector<GroupScratch> groupScratch_;
  std::vector<std::size_t> movedCounts_;  // per chunk
  SwarmState next_;
};

}  // namespace

double bell(double r) {
  if (r < 0.0) return 1.0;
  if (r > 1.0) return 0.0;
  const double r2 = r * r, r4 = r2 * r2, r6 = r4 * r2;
  return 1.0 - 4.0 / 9.0 * r6 + 17.0 / 9.0 * r4 - 22.0 / 9.0 * r2;
}

Vec3d GoalSpec::centerAt(double t) const {
  return keyTimes.empty() ? center : interpolateKeys(keyTimes, keyCenters, t);
}

bool GoalSpec::contains(const Vec3d& p, const Vec3d& c) const {
  if (kind == Kind::kSphere) return (p - c).squaredNorm() <= radius * radius;
  return ((p - c).cwiseAbs() - halfSize).maxCoeff() <= 0.0;
}

FieldParams readFieldParams(JsonReader& r, const ModelContext& context) {
  FieldParams p;
  const Aabb& dom = context.world.domain;
  // limits: docs/scenario.md#limits (speeds at most kMaxSpeed, lengths within [kMinLength, kMaxLength])
  p.speed = r.number("speed", p.speed, Range::positiveSpeed());
  p.costCells = readCells(r, "cost_cells", true, 2, 1024);
  if (static_cast<double>(p.costCells[0]) * p.costCells[1] * p.costCells[2] > 64e6) {
    r.fail("cost_cells", "more than 64 million cells");
  }
  p.costOrder = static_cast<int>(r.integer("cost_order", p.costOrder, 1, 2));
  const Vec3d costCell = dom.extent().cwiseQuotient(Vec3d(p.costCells[0], p.costCells[1], p.costCells[2]));
  const double unit = costCell.minCoeff();
  {
    JsonReader nz = r.object("noise", false);
    const std::string type = nz.choice("type", "curl", {"curl", "perlin", "white"});
    p.noise = type == "curl" ? NoiseKind::kCurl : type == "perlin" ? NoiseKind::kPerlin : NoiseKind::kWhite;
    p.scale = nz.number("scale", p.scale, Range::positive());
    checkNoiseFrequency(nz, "scale", dom, p.scale, 1.0 / unit);
    p.gain = nz.number("gain", p.gain, Range::speed());
    readSeeds(nz, "seeds", p.seeds);
    p.noiseCells = readCells(nz, "cells", false, 2, 1024);
    if (p.noiseCells[0] == 0) {
      // default: three samples per noise unit (l / scale), within [4, 256] per axis and 8M cells
      p.noiseCells = cellsForEdge(dom, unit / (3.0 * p.scale), 8e6);
    }
    nz.resolve("cells", Json::array({p.noiseCells[0], p.noiseCells[1], p.noiseCells[2]}));
    if (static_cast<double>(p.noiseCells[0]) * p.noiseCells[1] * p.noiseCells[2] > 64e6) {
      nz.fail("cells", "more than 64 million cells");
    }
    nz.finish();
  }
  p.rampDistance = r.number("ramp_distance", unit, Range::positive().limited(0.0, kMaxLength));
  p.pathWeight = r.number("path_weight", p.pathWeight, Range::positive());
  p.repulsionWeight = r.number("repulsion_weight", p.repulsionWeight, Range::nonNegative());
  for (JsonReader& g : r.objectArray("goals", false, 0)) p.goals.push_back(readGoal(g));
  p.minDistance = r.number("min_distance", p.minDistance, Range::lengthOrZero());
  p.agentRadius = r.number("agent_radius", 0.5 * p.minDistance, Range::nonNegative().limited(0.0, kMaxLength));
  p.mdePairs = r.choice("mde_pairs", "same_cell", {"same_cell", "neighbours"}) == "same_cell" ? MdePairs::kSameCell
                                                                                              : MdePairs::kNeighbours;
  if (r.has("phototaxis")) {
    JsonReader ph = r.object("phototaxis", false);
    p.phototaxis = true;
    p.light = ph.requireVec3("light", Range::coordinate());
    p.phototaxisProbability = ph.number("probability", 0.05, Range::closed(0.0, 1.0));
    p.phototaxisSpeed = ph.number("speed", 1.0, Range::speed());
    ph.finish();
  }
  return p;
}

std::shared_ptr<const ModelConfig> parseField(JsonReader& params, const ModelContext& context) {
  return std::make_shared<FieldConfig>(readFieldParams(params, context));
}

std::unique_ptr<Model> makeField(const FieldParams& params, const World& world) {
  return std::make_unique<FieldModel>(params, world);
}

}  // namespace swarmsim
