#include "models/shape/shape.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "core/lanes.hpp"
#include "core/parallel.hpp"
#include "fields/curl_noise.hpp"
#include "fields/noise_field.hpp"
#include "geometry/clearance.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/bswarm/interaction.hpp"
#include "models/field/mde.hpp"
#include "models/params_util.hpp"
#include "models/shape/assignment.hpp"
#include "models/shape/move_bound.hpp"
#include "models/shape/near_kernel.hpp"
#include "models/shape/near_list.hpp"
#include "models/shape/path.hpp"
#include "models/shape/sampling.hpp"
#include "models/shape/update_kernel.hpp"
#include "spatial/nearest.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kMaxForce = 1e6;  // m/s^2: weights of the forces

bool sameTopology(const TriangleMesh& a, const TriangleMesh& b) {
  return a.vertices.size() == b.vertices.size() && a.triangles == b.triangles;
}

// a seed per topology group of keys, from the sampling seed
std::uint64_t groupSeed(std::uint64_t seed, std::size_t group) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (group + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// room per insect in the near lists (NearLists): about the candidates within (1 + skin) times the K-th
// distance in three dimensions, with F_con's and MDE's few
std::size_t listCapacity(std::size_t K) { return 4 * K + 16; }

class ShapeConfig final : public ModelConfig {
 public:
  explicit ShapeConfig(const ShapeParams& p) : p_(p) {}
  std::unique_ptr<Model> build(const World& world) const override { return makeShape(p_, world); }

 private:
  ShapeParams p_;
};

class ShapeModel final : public Model {
 public:
  ShapeModel(const ShapeParams& p, const World& world) : p_(p), domain_(world.domain) {
    const Obstacles& obs = *world.obstacles;
    auto t0 = Clock::now();
    // obstacle distance: clearance, the ramp of eq. 8-9 and (with the walls) the noise's blend
    const GridSpec sdfSpec = GridSpec::covering(
        domain_.min, domain_.max,
        p_.sdfCells[0] > 0 ? p_.sdfCells : cellsForEdge(domain_, domain_.extent().maxCoeff() / 128.0, 4e6));
    Grid3<float> sdf = signedDistance(obs, sdfSpec);
    boundary_ = sdf;
    addBoxWalls(boundary_, domain_);
    clearance_ = ObstacleClearance(std::move(sdf), static_cast<float>(p_.agentRadius), !obs.empty());
    if (clearance_.any()) clearance_.prepareDistanceBound();  // eq. 8-9's look-up of who is near an obstacle
    tDistance_ = since(t0);

    // eq. 4: F_cur = ∇ × (η p(x / ρ)): lattice cell ρ, potential η (NoiseParams' potential factor is gain · unit / scale)
    t0 = Clock::now();
    NoiseParams np;
    np.scale = 1.0;
    np.unit = p_.rho;
    np.gain = p_.eta / p_.rho;
    np.seeds = p_.seeds;
    np.d0 = 0.5 * p_.rho;
    noise_ = NoiseField(NoiseFieldKind::kCurl, np, domain_, obs, p_.noiseCells, &boundary_);
    tNoise_ = since(t0);

    // topology groups of keys: a new group where the mesh's topology changes
    for (std::size_t k = 0; k < p_.keys.size(); ++k) {
      if (k == 0 || !p_.keys[k].sameTopology) groupStart_.push_back(k);
    }
    disRange_ = p_.disRange > 0.0 ? p_.disRange : domain_.extent().norm();
    spacing_ = spacingOf(p_.keys.front());
    tolerance_ = static_cast<float>(spacing_);
    if (!p_.path.points.empty()) path_ = BSplinePath(p_.path.points);
  }

  std::vector<std::string> statNames() const override {
    return {"shape_error_mean", "shape_error_p95", "within_tolerance", "mean_speed", "mde_fraction"};
  }

  void takeFrameStats(std::vector<double>& values) override {
    const std::size_t n = err_.size();
    double mean = 0.0, p95 = 0.0, within = 0.0, speed = 0.0;
    if (n > 0 && group_ >= 0) {
      double sum = 0.0, sumSpeed = 0.0;
      std::size_t in = 0;
      for (std::size_t k = 0; k < n; ++k) {  // in slot order: the same for any number of threads
        sum += err_[k];
        sumSpeed += speed_[k];
        in += err_[k] <= tolerance_ ? 1 : 0;
      }
      mean = sum / static_cast<double>(n);
      within = static_cast<double>(in) / static_cast<double>(n);
      speed = sumSpeed / static_cast<double>(n);
      sortScratch_ = err_;
      const std::size_t q = std::min(n - 1, static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(n))) - 1);
      std::nth_element(sortScratch_.begin(), sortScratch_.begin() + static_cast<std::ptrdiff_t>(q), sortScratch_.end());
      p95 = sortScratch_[q];
    } else if (n > 0) {
      double sumSpeed = 0.0;
      for (std::size_t k = 0; k < n; ++k) sumSpeed += speed_[k];
      speed = sumSpeed / static_cast<double>(n);
    }
    values = {mean, p95, within, speed,
              frameAgentSteps_ > 0 ? static_cast<double>(frameMoved_) / static_cast<double>(frameAgentSteps_) : 0.0};
    frameMoved_ = frameAgentSteps_ = 0;
  }

  Json facts() const override {
    Json keys = Json::array();
    for (const ShapeKey& k : p_.keys) {
      keys.push_back({{"time", k.time},
                      {"mesh", k.mesh->source},
                      {"area_m2", surfaceArea(*k.mesh)},
                      {"scale_up", k.scaleUp},
                      {"sample_spacing_m", spacingOf(k)}});
    }
    return {{"targets", keys}, {"samples", p_.count}, {"path_length_m", path_.length()}};
  }

  Json benchInfo() const override {
    const double steps = static_cast<double>(std::max<std::size_t>(1, timedSteps_));
    Json info = facts();
    info["noise_grid"] = noise_.direct() ? "direct" : std::to_string(noise_.spec().n[0]) + "x" +
                                                         std::to_string(noise_.spec().n[1]) + "x" +
                                                         std::to_string(noise_.spec().n[2]);
    info["t_distance"] = tDistance_;
    info["t_noise"] = tNoise_;
    info["t_sampling"] = tSampling_;
    info["t_assignment"] = tAssignment_;
    info["ms_interaction"] = 1e3 * tInteraction_ / steps;
    info["ms_grid"] = 1e3 * tGrid_ / steps;        // the grid, and the state copied into its order
    info["grid_builds"] = static_cast<double>(gridBuilds_) / steps;  // per step: the rest kept their cells
    info["ms_noise"] = 1e3 * tNoiseStep_ / steps;  // the curl noise and sample point of every insect
    info["ms_forces"] = 1e3 * tForces_ / steps;    // the per-insect pass, and the next step's cell size
    info["ms_mde"] = 1e3 * tMde_ / steps;
    info["timed_steps"] = timedSteps_;  // the steps these figures are over
    // per step: the share that bounded each insect's K-nearest search by last step's K (see step)
    info["near_kept"] = static_cast<double>(keptSteps_) / steps;
    info["theta"] = p_.theta;
    info["neighbours"] = p_.neighbours;
    info["list_rebuilds"] = static_cast<double>(rebuilds_) / (steps * static_cast<double>(std::max<std::size_t>(1, speed_.size())));
    info["ms_local"] = 1e3 * tLocal_ / steps;
    info["max_speed"] = p_.maxSpeed;
    return info;
  }

  void restartBenchTimers() override {
    tLocal_ = tInteraction_ = tForces_ = tMde_ = tGrid_ = tNoiseStep_ = 0.0;
    gridBuilds_ = rebuilds_ = timedSteps_ = keptSteps_ = 0;
  }

  // carried between steps: which topology group is active and the assignment
  // made when it began (it depends on where the insects were then), and the
  // frame's statistics counters
  void saveState(StateOut& out) const override {
    out.put<std::int64_t>(group_);
    out.putVector(assign_);
    out.put<std::uint64_t>(frameMoved_);
    out.put<std::uint64_t>(frameAgentSteps_);
    out.put<float>(cellHint_);  // the grid's cells, so the order of sums, depend on it
  }

  void loadState(StateIn& in, const World&) override {
    const std::int64_t g = in.get<std::int64_t>();
    std::vector<std::uint32_t> assign = in.getVector<std::uint32_t>();
    frameMoved_ = static_cast<std::size_t>(in.get<std::uint64_t>());
    frameAgentSteps_ = static_cast<std::size_t>(in.get<std::uint64_t>());
    cellHint_ = in.get<float>();
    lists_.clear();  // caches of positions the loaded state does not have
    nearKept_ = false;
    inGridOrder_ = false;
    if (!(cellHint_ >= 0.0f && cellHint_ <= static_cast<float>(p_.rAtt))) throw std::runtime_error("shape checkpoint: bad cell");
    if (g < -1 || g >= static_cast<std::int64_t>(groupStart_.size())) throw std::runtime_error("shape checkpoint: bad group");
    if (g >= 0) {
      prepareGroup(static_cast<std::size_t>(g), assign.size());
      assign_ = std::move(assign);
      forgetSampleOrder();
    }
    group_ = g;
  }

  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    const std::size_t n = s.size();
    const double t = info.time;
    const float dt = static_cast<float>(world.dt);

    // the topology group of this time; entering one samples its mesh and assigns the insects to the samples
    std::int64_t g = -1;
    for (std::size_t i = 0; i < groupStart_.size(); ++i) {
      if (t + 1e-9 * world.dt >= p_.keys[groupStart_[i]].time) g = static_cast<std::int64_t>(i);
    }
    if (g != group_) {
      group_ = g;
      if (g >= 0) {
        prepareGroup(static_cast<std::size_t>(g), n);
        assignFrom(s, t);
        forgetSampleOrder();
      }
    }

    // one grid per step: F_int, F_con and MDE all use it
    const auto tGrid0 = Clock::now();
    const bool nearest = p_.neighbours > 0;
    const float kh = static_cast<float>(p_.k * spacing_);
    const float md = static_cast<float>(p_.minDistance);
    const float mdReach = md + 2.0f * static_cast<float>(p_.maxSpeed) * dt;  // movement within the step
    // cells of at least k h (F_con), the MDE reach and (nearest-neighbour F_int) the K-th neighbour's distance
    // of most of the insects last step, so that most searches visit 27 cells. With the K nearest, while the
    // state is in the grid's order (as last step wrote it) and the insects have moved less than `grid_drift`
    // cells since the grid was built, the cells stay and only the positions are new (UniformGrid::moveSorted:
    // the queries reach that much farther across cells). Which grid answers never changes a result: every sum
    // runs over the neighbours that count, in id order.
    const float cellWanted = std::max({kh, mdReach, cellHint_, 1e-4f});
    const float cellNow = std::min({grid_.cellSize(0), grid_.cellSize(1), grid_.cellSize(2)});
    const auto drift = static_cast<float>(lastMaxMove_);
    const bool keepCells = nearest && inGridOrder_ && grid_.size() == n && n > 0 && p_.gridDrift > 0.0 &&
                           grid_.slack() + drift <= static_cast<float>(p_.gridDrift) * cellNow &&
                           cellWanted <= 1.1f * cellNow && cellWanted >= 0.75f * cellNow;
    if (keepCells) {
      grid_.moveSorted(s.px.data(), s.py.data(), s.pz.data(), drift);
    } else {
      grid_.build(s.px.data(), s.py.data(), s.pz.data(), n, cellWanted);
      ++gridBuilds_;
    }
    // the state index of each sorted position: the grid's order, or where the state already is
    if (identity_.size() != n) {
      identity_.resize(n);
      for (std::size_t k = 0; k < n; ++k) identity_[k] = static_cast<std::uint32_t>(k);
    }
    bool cellsKept = keepCells;
    for (auto* a : {&vx_, &vy_, &vz_, &fx_, &fy_, &fz_, &tx_, &ty_, &tz_, &nvx_, &nvy_, &nvz_, &tgx_, &tgy_, &tgz_}) {
      a->resize(n);
    }
    ids_.swap(lastIds_);  // last step's ids by sorted position: this step's by state index
    ids_.resize(n);
    sample_.swap(lastSample_);
    sample_.resize(n);
    const bool assigned = assign_.size() == n;
    err_.resize(n);
    speed_.resize(n);
    // position and velocity of each sorted position also as one row of eight floats (near_kernel.hpp,
    // kRowFloats), half a cache line: where the near sums look up a neighbour's position, its velocity comes
    // with it. A last row at n is far from everything.
    float* rows = rows_.resize(kRowFloats * (n + 1));
    newPos_.resize(n);
    std::atomic<bool> asLastStep{lastIds_.size() == n};  // every insect where last step wrote it
    const float* gx = grid_.sortedX().data();
    const float* gy = grid_.sortedY().data();
    const float* gz = grid_.sortedZ().data();
    for (std::size_t a = 0; a < kRowFloats; ++a) rows[kRowFloats * n + a] = a < 3 ? 3.0e38f : 0.0f;
    const LaneSet rowLanes = laneSet();
    const auto copyIn = [&](const std::vector<std::uint32_t>& order, bool inOrder) {
      parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
        bool allSame = true;
        if (inOrder) {  // (the grid kept its cells: order[k] = k, and the copies run whole vectors)
          std::copy(s.vx.begin() + first, s.vx.begin() + last, vx_.begin() + first);
          std::copy(s.vy.begin() + first, s.vy.begin() + last, vy_.begin() + first);
          std::copy(s.vz.begin() + first, s.vz.begin() + last, vz_.begin() + first);
          std::copy(s.id.begin() + first, s.id.begin() + last, ids_.begin() + first);
          std::copy(identity_.begin() + first, identity_.begin() + last, newPos_.begin() + first);
        }
        for (std::size_t k = first; k < last; ++k) {
          const std::uint32_t i = order[k];
          if (!inOrder) {
            vx_[k] = s.vx[i];
            vy_[k] = s.vy[i];
            vz_[k] = s.vz[i];
            newPos_[i] = static_cast<std::uint32_t>(k);  // last step's sorted position (the state index) -> this step's
            ids_[k] = s.id[i];
          }
          // the insect's sample: where last step left it when the state is as last step wrote it (it is, but
          // for the step after a resume), else through the id (a random access)
          const bool same = i < lastIds_.size() && lastIds_[i] == ids_[k];
          if (assigned) sample_[k] = same ? lastSample_[i] : assign_[ids_[k]];
          allSame = allSame && same;
        }
        if (!allSame) asLastStep.store(false, std::memory_order_relaxed);  // rare: no contention
        fillRows(gx, gy, gz, vx_.data(), vy_.data(), vz_.data(), first, last - first, rows, rowLanes);
      });
    };
    copyIn(cellsKept ? identity_ : grid_.order(), cellsKept);
    if (cellsKept && !asLastStep.load(std::memory_order_relaxed)) {
      // the state is not in the order the kept grid has (it was changed between the steps): a new grid
      grid_.build(s.px.data(), s.py.data(), s.pz.data(), n, cellWanted);
      ++gridBuilds_;
      cellsKept = false;
      asLastStep.store(lastIds_.size() == n, std::memory_order_relaxed);
      copyIn(grid_.order(), false);
    }
    const std::vector<std::uint32_t>& order = cellsKept ? identity_ : grid_.order();

    tGrid_ += since(tGrid0);

    // F_int (eq. 2-3): over the nearest neighbours (below, with F_con), or over every insect within r_att
    // with the far field approximated
    auto t0 = Clock::now();
    if (!nearest) {
      const ZoneParams zones = ZoneParams::of(p_.rRep, p_.rAli, p_.rAtt, p_.wRep, p_.wAli, p_.wAtt);
      forces_.compute(grid_, vx_.data(), vy_.data(), vz_.data(), zones, static_cast<float>(p_.theta), fx_.data(),
                      fy_.data(), fz_.data());
    }
    tInteraction_ += since(t0);

    // the targets now: keyframe interpolation inside the group, then the path
    t0 = Clock::now();
    const bool shaped = group_ >= 0;
    std::size_t keyA = 0, keyB = 0;
    float f = 0.0f;
    if (shaped) keyPair(t, keyA, keyB, f);
    const float alpha = static_cast<float>(p_.alpha);
    const float wCon = static_cast<float>(p_.wCon), wDis = static_cast<float>(p_.wDis);
    const float sigma = static_cast<float>(p_.omega * spacing_);
    const float invRange = static_cast<float>(1.0 / disRange_);
    const float vmax = static_cast<float>(p_.maxSpeed), L = static_cast<float>(p_.obstacleRange);
    const float* sx = grid_.sortedX().data();
    const float* sy = grid_.sortedY().data();
    const float* sz = grid_.sortedZ().data();
    const bool obstacles = clearance_.any();
    const Grid3<float>::Sampler sdfSample = clearance_.sdf().sampler();  // = clearance_.distance, set up once
    const float rAtt = static_cast<float>(p_.rAtt);
    const auto K = static_cast<std::size_t>(std::max(0, p_.neighbours));
    const float reachSlack = 2.0f * vmax * dt;  // the K-th neighbour's distance changes by at most this in a step
    if (scratch_.size() < static_cast<std::size_t>(threadCount())) scratch_.resize(static_cast<std::size_t>(threadCount()));
    const float inv2s2 = 1.0f / (2.0f * sigma * sigma);

    const LaneSet lanes = laneSet();
    const TargetPlacement placement = shaped && n > 0 ? placementAt(t, keyA, keyB, f) : TargetPlacement{};
    // eq. 4's curl noise of every insect first, several at a time (the same bits as one at a time)
    for (auto* a : {&cnx_, &cny_, &cnz_}) a->resize(n);
    // (a thread done with its own range takes from the other's: the blended curl near a boundary costs far more)
    parallelForBalancedChunks(n, 256, [&](std::size_t first, std::size_t last) {
      noise_.evaluateBatch(sx + first, sy + first, sz + first, last - first, cnx_.data() + first, cny_.data() + first,
                           cnz_.data() + first);
      // each insect's sample point now (random accesses, together: their cache misses overlap)
      if (shaped)
        placeTargets(placement, sample_.data(), first, last - first, tgx_.data(), tgy_.data(), tgz_.data(), lanes);
    });

    tNoiseStep_ += since(t0);
    t0 = Clock::now();
    const bool asLast = asLastStep.load(std::memory_order_relaxed);
    const ZonalSum zones(static_cast<float>(p_.rRep), static_cast<float>(p_.rAli), rAtt, static_cast<float>(p_.wRep),
                         static_cast<float>(p_.wAli), static_cast<float>(p_.wAtt));
    // F_int over the K nearest within r_att of insect k. Its K nearest are no farther than the farthest of
    // the K it had last step (still K other insects), so one search of that radius finds them: within the
    // block when the block is complete that far about k, else on the grid. Without last step's K (the first
    // step, a resume, fewer than K within r_att) spatial/nearest.hpp widens from the block. The K are
    // sorted, so the result depends on none of this, only on the positions.
    if (nearest) {
      // by id: last step's K nearest and how many (a bound for this step's search only); the near lists;
      // this step's sorted position of every id
      if (reachLast_.size() != n) reachLast_.assign(n, cellHint_);
      lists_.reset(n, listCapacity(K), static_cast<float>(p_.listSkin));
      reach_.resize(n);
      if (nearLast_.size() != n * K) nearKept_ = false;  // (kept for another swarm size, or never)
      // the lists hold last step's sorted positions, which are this step's state indices only while the state
      // is in the order last step wrote it: else (the first step, a resume, a new target) they go
      if (!asLast) lists_.clear();
      lists_.beginStep(cellsKept && asLast);  // the state in place: each list stays in its slot
    }
    // keep this step's K nearest of each insect for the next step's bound where the insects move fast for their
    // spacing (two of last step's largest moves beyond a tenth of the cell, about the K-th distance): there the
    // bound from last step's K-th distance alone takes in many more than K, elsewhere the K look-ups cost more
    const bool keepNear = nearest && 2.0 * lists_.lastMove() > 0.1 * static_cast<double>(cellHint_);
    if (keepNear) nearNext_.resize(n * K);  // (allocated only where kept: 8 K bytes per insect for the two)
    if (nearKept_) ++keptSteps_;
    const ZoneLanes zoneLanes = {zones.rRep2, zones.rAli2, zones.rAtt2, {zones.w[0], zones.w[1], zones.w[2]}};
    const bool avx = lanes != LaneSet::kSse;  // for the kernels without an AVX2 variant
    const bool rowsZonal = zonalFromRows(lanes);
    const bool fused = nearSumsLanes(lanes);
    // F_con (into fCon) and F_int (returned) of sorted insect k from its near-list candidates. Every sum runs
    // over the entries that count, packed in id order, so it depends on the positions only.
    const float mdReach2 = mdReach * mdReach * (1.0f + 1e-5f);  // float slack: a larger radius is harmless
    if (nearest) {
      mdeAt_.resize(n);
      mdeCount_.resize(n);
      for (NearScratch& ns : scratch_) ns.mde.clear();
    }
    const auto nearForces = [&](std::size_t k, NearScratch& ns, Vec3& fCon) -> Vec3 {
      const float qx = sx[k], qy = sy[k], qz = sz[k];
      // last step's data of this insect sit in its state index (last step's sorted position), unless the
      // state is not as last step left it (the step after a resume or a new target)
      const std::uint32_t from = asLast ? order[k] : NearLists::kNone;
      // the candidates: every insect within `cover` now, from the list when it reaches F_con's and MDE's
      // radii, else a new one of 1 + skin times the larger of those and last step's K-th distance
      // F_int's K nearest within r_att lie within last step's K-th distance plus two of last step's largest
      // moves (those K are still there): `guess`, the first radius searched; the whole coverage when it
      // holds fewer than K
      const bool known = from != NearLists::kNone;
      float lastReach = 0.0f, guess = rAtt;
      if (known) {
        lastReach = reachLast_[from];
        guess = std::min(rAtt, lastReach + static_cast<float>(lists_.lastMoveBound(from, lastReach)) * 1.001f + 1e-6f);
        // tighter, where last step kept its K nearest: the farthest of them now (K other insects, so the K
        // nearest now are no farther; the squared distance as gatherClassify computes it, the root with a
        // float slack)
        const std::uint32_t* prev = nearKept_ ? nearLast_.data() + std::size_t{from} * K : nullptr;
        if (prev && prev[0] != NearLists::kNone) {
          const float far2 = farthestRow2(K, prev, newPos_.data(), rows, n + 1, Vec3(qx, qy, qz), lanes);
          guess = std::min(guess, std::sqrt(far2) * (1.0f + 1e-5f) + 1e-7f);
        }
      } else {
        // no last step here (the first step, a resume, a new target): the K-th distance now, from the grid
        // searching outward (spatial/nearest.hpp)
        std::vector<std::uint64_t>& found = ns.found;  // (not keys: its room is the candidates')
        found.clear();
        if (nearestKeys(grid_, static_cast<std::uint32_t>(k), K, 0.0f, std::max({cellHint_, kh, 1e-3f * rAtt}), rAtt,
                        found) == K) {
          lastReach = guess = std::min(rAtt, std::sqrt(keyDistance2(found[K - 1])) * (1.0f + 1e-5f));
        } else {
          lastReach = rAtt;
        }
      }
      const float need = std::max({kh, mdReach, guess});
      float cover = lists_.coverage(from);
      std::size_t m = 0;
      const std::uint32_t* cand = nullptr;
      if (cover >= need) {
        cand = lists_.keep(from, static_cast<std::uint32_t>(k), newPos_.data(), m);
      } else {
        cover = std::min(rAtt, (1.0f + lists_.skin()) * std::max(need, lastReach));
        cover = std::max({cover, kh, mdReach});
        cand = lists_.build(static_cast<std::uint32_t>(k), cover, grid_, ids_.data(), ns.ids, ns.sortKeys, m, lanes);
        ++ns.rebuilds;
      }
      std::size_t counts[3];
      std::size_t mk = 0;
      // all at once on AVX-512 where it can (nearSums: the same results), else step by step
      NearSums sums;
      const float first = std::min({cover, rAtt, guess});
      const bool together =
          fused && nearSums(m, cand, rows, static_cast<std::uint32_t>(n), Vec3(qx, qy, qz),
                            Vec3(vx_[k], vy_[k], vz_[k]), kh, inv2s2, first * first, mdReach2, K, zoneLanes, ns, sums);
      if (together) std::copy(sums.counts, sums.counts + 3, counts);
      for (; !together;) {
        // their sorted positions and positions (the one random access of each), offsets, squared distances,
        // and who counts for F_con, F_int (within the first radius) and MDE
        const float reach = std::min({cover, rAtt, guess});
        gatherClassify(m, cand, rows, static_cast<std::uint32_t>(n), Vec3(qx, qy, qz), kh, reach * reach,
                       mdReach2, ns, lanes, counts);
        mk = counts[1];
        if (mk < K && reach < std::min(cover, rAtt)) {  // fewer than K within the first radius: all of cover
          const float c2 = std::min(cover, rAtt) * std::min(cover, rAtt);
          mk = 0;
          for (std::size_t e = 0; e < m; ++e) {
            ns.keys[mk] = neighbourKey(ns.cd2[e], static_cast<std::uint32_t>(e));  // ties: the lower id
            mk += static_cast<std::size_t>(ns.cd2[e] <= c2);
          }
        }
        if (mk >= K || cover >= rAtt) break;
        // fewer than K within the coverage, which is short of r_att: a wider list (rare)
        cover = std::min(rAtt, 1.5f * cover);
        cand = lists_.build(static_cast<std::uint32_t>(k), cover, grid_, ids_.data(), ns.ids, ns.sortKeys, m, lanes);
        ++ns.rebuilds;
      }
      if (shaped) {  // F_con over its entries, packed in id order (by gatherClassify)
        Vec3 sum;
        int count = 0;
        if (together && sums.conSummed) {
          sum = sums.conSum;
          count = sums.conCount;
        } else {
          constraintSumScratch(counts[0], kh, inv2s2, ns, avx, sum, count);
        }
        fCon = count > 0 ? Vec3(sum * (-wCon / static_cast<float>(count))) : Vec3::Zero();
      }
      std::uint64_t* keys = ns.keys.data();  // F_int's candidates (gatherClassify's, or those of the loop above)
      // MDE's candidates (within its reach now, in id order), kept for the MDE pass in this thread's store
      const std::size_t mm = counts[2];
      mdeCount_[k] = static_cast<std::uint32_t>(mm);
      mdeAt_[k] = {static_cast<std::uint32_t>(threadIndex()), static_cast<std::uint32_t>(ns.mde.size())};
      for (std::size_t c = 0; c < mm; ++c) ns.mde.push_back(cand[ns.mdeIdx[c]]);
      if (together) {  // (K of them)
        if (keepNear) std::copy(ns.chosen.data(), ns.chosen.data() + K, nearNext_.data() + k * K);
        reach_[k] = std::sqrt(sums.far2);
        return sums.fInt;
      }
      // F_int over the K nearest within r_att, in id order
      mk = keepSmallest(keys, mk, K);
      // their sorted positions, and the farthest (the largest key)
      std::uint64_t top = 0;
      std::uint32_t* js = ns.chosen.data();  // (room for the candidates: gatherClassify)
      for (std::size_t q = 0; q < mk; ++q) {
        js[q] = ns.cj[keyIndex(keys[q])];
        top = std::max(top, keys[q]);
      }
      if (keepNear) {  // for the next step's bound (in slot k: its state index then)
        std::uint32_t* next = nearNext_.data() + k * K;
        if (mk == K) {
          std::copy(js, js + K, next);
        } else {
          next[0] = NearLists::kNone;
        }
      }
      if (rowsZonal) {  // straight from their rows
        reach_[k] = mk == K ? std::sqrt(keyDistance2(top)) : rAtt;
        return zonalForceRows(mk, js, rows, static_cast<std::uint32_t>(n), Vec3(qx, qy, qz),
                              Vec3(vx_[k], vy_[k], vz_[k]), zoneLanes);
      }
      float far2 = 0.0f;
      const float vkx = vx_[k], vky = vy_[k], vkz = vz_[k];
      for (std::size_t q = 0; q < mk; ++q) {
        const std::uint32_t e = keyIndex(keys[q]);
        const float* vj = rows + kRowFloats * std::size_t{ns.cj[e]} + 4;  // in the line gatherClassify loaded
        far2 = std::max(far2, ns.cd2[e]);
        ns.dx[q] = ns.cx[e];
        ns.dy[q] = ns.cy[e];
        ns.dz[q] = ns.cz[e];
        ns.d2[q] = ns.cd2[e];
        ns.ux[q] = vj[0] - vkx;
        ns.uy[q] = vj[1] - vky;
        ns.uz[q] = vj[2] - vkz;
      }
      reach_[k] = mk == K ? std::sqrt(far2) : rAtt;
      return zonalForce(mk, zoneLanes, ns, avx);
    };

    // the rest of each insect's step, given F_int and F_con's sum: eq. 1, F_dis, Newton's second law and the top
    // speed on SIMD lanes (update_kernel.hpp), then eq. 8-9 one insect at a time: near an obstacle the velocity
    // ramps toward the tangent (only an approach is bent)
    InsectUpdate update;
    update.x = {sx, sy, sz};
    update.v = {vx_.data(), vy_.data(), vz_.data()};
    update.noise = {cnx_.data(), cny_.data(), cnz_.data()};
    if (shaped) update.sample = {tgx_.data(), tgy_.data(), tgz_.data()};
    update.nv = {nvx_.data(), nvy_.data(), nvz_.data()};
    update.t = {tx_.data(), ty_.data(), tz_.data()};
    update.alpha = alpha;
    update.wDis = wDis;
    update.invRange = invRange;
    update.maxSpeed = vmax;
    update.dt = dt;
    update.shaped = shaped;
    constexpr std::size_t kBlock = 64;  // insects updated together
    struct alignas(64) BlockForces {
      float f[6][kBlock];  // F_int x, y, z, F_con's x, y, z
    };
    // insects [a, b): F_int's components at fInt[c][0, b - a), F_con's in bf
    const auto updateBlock = [&](std::size_t a, std::size_t b, const float* const fInt[3], const BlockForces& bf) {
      const float* const fCon[3] = {bf.f[3], bf.f[4], bf.f[5]};
      updateInsects(update, a, b - a, fInt, fCon, lanes);
      if (!obstacles) return;
      for (std::size_t k = a; k < b; ++k) {
        const Vec3 x(sx[k], sy[k], sz[k]);
        if (clearance_.distanceBound(sdfSample, x) >= L) continue;  // (most insects: surely beyond L)
        const float dist = sdfSample(x);
        if (!(dist < L)) continue;
        Vec3 v(nvx_[k], nvy_[k], nvz_[k]);
        const Vec3 nrm = clearance_.normal(x);
        const float vn = nrm.dot(v);
        if (!(vn < 0.0f)) continue;
        v -= nrm * (vn * (1.0f - static_cast<float>(ramp(static_cast<double>(dist / L)))));
        nvx_[k] = v.x();
        nvy_[k] = v.y();
        nvz_[k] = v.z();
        tx_[k] = x.x() + v.x() * dt;
        ty_[k] = x.y() + v.y() * dt;
        tz_[k] = x.z() + v.z() * dt;
      }
    };

    if (nearest) {
      // each thread takes one contiguous range of insects, the same as in the loops before and after this one:
      // most of what it reads it wrote itself (another core's cache lines cost more than the uneven work), and
      // a thread done with its own goes on with what is left of the other's
      parallelForBalancedChunks(n, kBlock, [&](std::size_t a, std::size_t b) {
        NearScratch& ns = scratch_[static_cast<std::size_t>(threadIndex())];
        BlockForces bf;
        for (std::size_t k = a; k < b; ++k) {
          Vec3 fCon = Vec3::Zero();
          const Vec3 fInt = nearForces(k, ns, fCon);
          for (int c = 0; c < 3; ++c) {
            bf.f[c][k - a] = fInt[c];
            bf.f[3 + c][k - a] = fCon[c];
          }
        }
        const float* const fInt[3] = {bf.f[0], bf.f[1], bf.f[2]};
        updateBlock(a, b, fInt, bf);
      });
    } else {
      parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
        for (std::size_t a = first; a < last; a += kBlock) {
          const std::size_t b = std::min(last, a + kBlock);
          BlockForces bf;
          for (std::size_t k = a; k < b; ++k) {
            ShapeConstraintSum con(kh, sigma);
            if (shaped) {
              grid_.forEachNeighbor(sx[k], sy[k], sz[k], kh,
                                    [&](std::uint32_t j, float dx, float dy, float dz, float d2) {
                                      if (j != k) con.add(dx, dy, dz, d2);
                                    });
            }
            const Vec3 fCon = con.force(wCon);
            for (int c = 0; c < 3; ++c) bf.f[3 + c][k - a] = fCon[c];
          }
          const float* const fInt[3] = {fx_.data() + a, fy_.data() + a, fz_.data() + a};
          updateBlock(a, b, fInt, bf);
        }
      });
    }
    if (nearest) {
      // the next step's cell: the 90th percentile of the K-th neighbour distances, plus a step's movement (fewer
      // insects need the grid search beyond their block than with the median; measured on moon and horse), over
      // every stride-th insect in grid order, at most about 1,024 of them (on one thread, while the others wait).
      // The cell size is a speed choice only:
      // no sum depends on it (the sums run over the neighbours that count, in id order)
      reach_.swap(reachLast_);
      if (keepNear) nearLast_.swap(nearNext_);
      nearKept_ = keepNear;
      if (n > 0) {
        const std::size_t stride = std::max<std::size_t>(1, n / 1024), samples = (n + stride - 1) / stride;
        sortScratch_.resize(samples);
        for (std::size_t i = 0; i < samples; ++i) sortScratch_[i] = reachLast_[i * stride];
        const std::size_t q = samples - 1 - samples / 10;
        std::nth_element(sortScratch_.begin(), sortScratch_.begin() + static_cast<std::ptrdiff_t>(q),
                         sortScratch_.end());
        cellHint_ = std::min(rAtt, sortScratch_[q] + reachSlack);
      }
    }
    tForces_ += since(t0);

    // minimum distance enforcement on the moved positions (neighbours from this step's grid: nobody moved
    // more than max speed · dt), then obstacle clearance and the domain; the state is rewritten in grid order
    t0 = Clock::now();
    next_.resizeStorage(n);
    movedFlag_.resize(n);
    const Vec3 lo = domain_.min.cast<float>(), hi = domain_.max.cast<float>();
    const float md2 = md * md;
    // how insect j, at its moved position, acts on insect k: nearer than d_min (MDE's kernel pushes), exactly
    // where it is (the pair separates along x), or not at all
    struct Acts {
      bool near, same;
    };
    const auto acts = [&](std::size_t k, std::uint32_t j) {
      const float qx = tx_[k], qy = ty_[k], qz = tz_[k];
      const float dx = tx_[j] - qx, dy = ty_[j] - qy, dz = tz_[j] - qz;
      const float d2 = dx * dx + dy * dy + dz * dz;
      return Acts{d2 < md2 && d2 > 0.0f, tx_[j] == qx && ty_[j] == qy && tz_[j] == qz};
    };
    // MDE of sorted insect k from its candidates of the near pass (every insect within MDE's reach at the
    // step's start, in id order: nobody moved more than max speed · dt): the neighbours closer than d_min at
    // the moved positions, packed in id order; returns whether it was pushed
    const auto listPush = [&](std::size_t k, Vec3& x) -> bool {
      NearScratch& ns = scratch_[static_cast<std::size_t>(threadIndex())];
      const float qx = tx_[k], qy = ty_[k], qz = tz_[k];
      const std::uint32_t id = ids_[k];
      const std::size_t m = mdeCount_[k];
      if (m == 0) {  // nobody within MDE's reach (most insects): no push (the + 0 of an empty one)
        x += Vec3::Zero();
        return false;
      }
      const std::uint32_t* cand = mdeCandidates(k);
      ns.reserveCandidates(m);
      std::size_t mc = 0, nz = 0;
      for (std::size_t e = 0; e < m; ++e) {
        const std::uint32_t j = cand[e];
        const Acts a = acts(k, j);
        ns.ux[mc] = tx_[j];
        ns.uy[mc] = ty_[j];
        ns.uz[mc] = tz_[j];
        mc += a.near ? 1 : 0;
        if (a.same) ns.cj[nz++] = ids_[j];  // exactly coincident (rare)
      }
      MdePush kernel(md);
      kernel.start(qx, qy, qz);
      kernel.add(ns.ux.data(), ns.uy.data(), ns.uz.data(), 0, static_cast<std::uint32_t>(mc));
      x += kernel.push();
      // an exactly coincident neighbour: the pair separates along x, ordered by id
      for (std::size_t q = 0; q < nz; ++q) x.x() += (id < ns.cj[q] ? -0.5f : 0.5f) * md;
      return kernel.hits() > 0 || nz > 0;
    };
    if (nearest) {
      move_.resize(3 * n + 1);  // (+ 1: LocalMoveBound reads four floats at a time)
      moveBox_.assign(static_cast<std::size_t>(chunkCount(n)), MoveBox{});
    }
    const auto insectEnd = [&](std::size_t k) {
      Vec3 x(tx_[k], ty_[k], tz_[k]);
      bool pushed = false;
      if (md > 0.0f && nearest) {
        pushed = listPush(k, x);
      } else if (md > 0.0f) {
        MdePush kernel(md);
        kernel.start(tx_[k], ty_[k], tz_[k]);
        grid_.forEachRun(sx[k], sy[k], sz[k], mdReach,
                         [&](std::uint32_t b, std::uint32_t e) { kernel.add(tx_.data(), ty_.data(), tz_.data(), b, e); });
        x += kernel.push();
        pushed = kernel.hits() > 0;
        if (kernel.zeros() > 1) {
          // an exactly coincident neighbour (rare): the pair separates along x, ordered by id
          grid_.forEachRun(sx[k], sy[k], sz[k], mdReach, [&](std::uint32_t b, std::uint32_t e) {
            for (std::uint32_t j = b; j < e; ++j) {
              if (j == k || tx_[j] != tx_[k] || ty_[j] != ty_[k] || tz_[j] != tz_[k]) continue;
              x.x() += (ids_[k] < ids_[j] ? -0.5f : 0.5f) * md;
              pushed = true;
            }
          });
        }
      }
      x = clearance_.apply(x).cwiseMax(lo).cwiseMin(hi);
      if (nearest) {
        move_[3 * k] = x.x() - sx[k];
        move_[3 * k + 1] = x.y() - sy[k];
        move_[3 * k + 2] = x.z() - sz[k];
      }
      movedFlag_[k] = pushed ? 1 : 0;
      next_.px[k] = x.x();
      next_.py[k] = x.y();
      next_.pz[k] = x.z();
      next_.vx[k] = nvx_[k];
      next_.vy[k] = nvy_[k];
      next_.vz[k] = nvz_[k];
      next_.id[k] = ids_[k];
      speed_[k] = Vec3(nvx_[k], nvy_[k], nvz_[k]).norm();
      if (shaped) err_[k] = (Vec3(tgx_[k], tgy_[k], tgz_[k]) - x).norm();
    };
    // most insects neither MDE nor an obstacle moves: eight at a time with the same bits (update_kernel.hpp),
    // then insectEnd for the others (balanced: only some insects have neighbours to push them)
    const bool listed = md > 0.0f && nearest;
    InsectWrite write;
    for (std::size_t c = 0; c < 3; ++c) {
      write.lo[c] = lo[static_cast<Eigen::Index>(c)];
      write.hi[c] = hi[static_cast<Eigen::Index>(c)];
    }
    write.t = {tx_.data(), ty_.data(), tz_.data()};
    write.start = {sx, sy, sz};
    write.nv = {nvx_.data(), nvy_.data(), nvz_.data()};
    write.target = {tgx_.data(), tgy_.data(), tgz_.data()};
    write.ids = ids_.data();
    write.addZero = listed;
    write.shaped = shaped;
    write.p = {next_.px.data(), next_.py.data(), next_.pz.data()};
    write.v = {next_.vx.data(), next_.vy.data(), next_.vz.data()};
    write.id = next_.id.data();
    write.move = nearest ? move_.data() : nullptr;
    write.moved = movedFlag_.data();
    write.speed = speed_.data();
    write.err = err_.data();
    const bool anyLanes = md <= 0.0f || listed;  // (else every insect takes the grid's MDE)
    parallelForBalancedChunks(n, 64, [&](std::size_t a, std::size_t b) {
      if (!anyLanes) {
        for (std::size_t k = a; k < b; ++k) insectEnd(k);
        return;
      }
      writeInsects(write, a, b - a, lanes);
      for (std::size_t k = a; k < b; ++k) {
        bool again = !clearance_.leaves(Vec3(tx_[k], ty_[k], tz_[k]));
        if (listed && !again && mdeCount_[k] != 0) {
          // MDE moves the insect only where one of its candidates acts on it (listPush's own test); with none,
          // listPush adds +0 and the write stands
          const std::uint32_t* cand = mdeCandidates(k);
          for (std::size_t e = 0; e < mdeCount_[k] && !again; ++e) {
            const Acts act = acts(k, cand[e]);
            again = act.near || act.same;
          }
        }
        if (again) insectEnd(k);
      }
    });
    std::size_t moved = 0;
    for (std::size_t k = 0; k < n; ++k) moved += movedFlag_[k];
    if (nearest) {
      // how far the insects moved: the largest move (for the grid's cells), and each one's move relative to the
      // middle c of the moves' bounding box (for the lists and the K-th distance bound: two insects' offset
      // changed by at most |d_i - c| + |d_j - c| for any c, so a swarm travelling together keeps its lists).
      // Maxima and minima: the same for any order.
      parallelChunks(n, [&](std::size_t first, std::size_t last, int chunk) {
        MoveBox box;
        for (std::size_t k = first; k < last; ++k) {
          const float* d = move_.data() + 3 * k;
          for (int a = 0; a < 3; ++a) {
            box.lo[a] = std::min(box.lo[a], d[a]);
            box.hi[a] = std::max(box.hi[a], d[a]);
          }
          box.move2 = std::max(box.move2, d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
        if (localPause_ == 0) {  // where the insects started (for the local bound)
          for (std::size_t k = first; k < last; ++k) {
            const float p[3] = {sx[k], sy[k], sz[k]};
            for (int a = 0; a < 3; ++a) {
              box.from[a] = std::min(box.from[a], p[a]);
              box.to[a] = std::max(box.to[a], p[a]);
            }
          }
        }
        moveBox_[static_cast<std::size_t>(chunk)] = box;
      });
      MoveBox all;
      for (const MoveBox& b : moveBox_) {
        for (int a = 0; a < 3; ++a) {
          all.lo[a] = std::min(all.lo[a], b.lo[a]);
          all.hi[a] = std::max(all.hi[a], b.hi[a]);
          all.from[a] = std::min(all.from[a], b.from[a]);
          all.to[a] = std::max(all.to[a], b.to[a]);
        }
        all.move2 = std::max(all.move2, b.move2);
      }
      const float move2 = all.move2;
      const float c[3] = {0.5f * (all.lo[0] + all.hi[0]), 0.5f * (all.lo[1] + all.hi[1]),
                          0.5f * (all.lo[2] + all.hi[2])};
      ownMove_.resize(n);
      relMax_.assign(static_cast<std::size_t>(chunkCount(n)), 0.0f);
      parallelChunks(n, [&](std::size_t first, std::size_t last, int chunk) {
        float r = 0.0f;
        for (std::size_t k = first; k < last; ++k) {  // (an upper bound: float rounding of the norm and of c's offset)
          const float* d = move_.data() + 3 * k;
          const float ex = d[0] - c[0], ey = d[1] - c[1], ez = d[2] - c[2];
          ownMove_[k] = std::sqrt(ex * ex + ey * ey + ez * ez) * (1.0f + 1e-5f) + 1e-7f;
          r = std::max(r, ownMove_[k]);
        }
        relMax_[static_cast<std::size_t>(chunk)] = r;
      });
      float rel = 0.0f;
      for (const float r : relMax_) rel = std::max(rel, r);
      lastMaxMove_ = static_cast<double>(std::sqrt(move2)) * (1.0 + 1e-5) + 1e-7;
      // the lists built this step (counts: the same for any thread count)
      std::size_t built = 0;
      for (NearScratch& ns : scratch_) {
        built += ns.rebuilds;
        ns.rebuilds = 0;
      }
      rebuilds_ += built;
      builtRate_ = 0.9 * builtRate_ + 0.1 * static_cast<double>(built);  // (lists are built in waves: smoothed)
      // and relative to the insects about each (move_bound.hpp), in blocks that take in most lists with a
      // step's movement to spare; a swarm spread over more blocks than a quarter of its insects goes without.
      // Worth its cost where it saves lists: a list built costs about 30 times what the bound costs an insect
      // (instruction counts), and with it the lists last gain() times as long. Where it saved less than its
      // cost this step (a swarm still gathering from all sides), the next 15 steps go without it (speed only)
      const double edge =
          1.25 * (1.0 + static_cast<double>(lists_.skin())) * static_cast<double>(std::max({cellHint_, kh, mdReach})) +
          2.0 * lastMaxMove_;
      localMove_.resize(n);
      const auto tl0 = Clock::now();
      bool local = false;
      if (localPause_ > 0) {
        --localPause_;
      } else {
        local = localBound_.compute(n, sx, sy, sz, all.from, all.to, move_.data(), edge, lastMaxMove_, n / 4 + 4096,
                                    localMove_.data(), ownMove_.data(), rel);
        const double saved = builtRate_ * (localBound_.gain() - 1.0);  // lists a step, about
        if (!local || 30.0 * saved < static_cast<double>(n)) localPause_ = 15;
      }
      tLocal_ += since(tl0);
      lists_.advance(static_cast<double>(rel), ownMove_, local ? &localMove_ : nullptr, localBound_.reach());
    }
    tMde_ += since(t0);
    s.swapStorage(next_);
    inGridOrder_ = true;  // the state is in this step's grid order now

    frameMoved_ += moved;
    frameAgentSteps_ += n;
    if (info.step == 0) {
      restartBenchTimers();  // the first step sizes every buffer: not timed
    } else {
      ++timedSteps_;
    }
  }

 private:
  // h = sqrt(A / N) of a key's mesh (eq. 5: the mean spacing of its samples)
  double spacingOf(const ShapeKey& k) const {
    return std::sqrt(surfaceArea(*k.mesh) / static_cast<double>(std::max<std::int64_t>(1, p_.count)));
  }

  // samples of group g's mesh (n of them) at each of its keys
  void prepareGroup(std::size_t g, std::size_t n) {
    const auto t0 = Clock::now();
    const std::size_t first = groupStart_[g];
    const std::size_t last = g + 1 < groupStart_.size() ? groupStart_[g + 1] : p_.keys.size();
    const TriangleMesh& mesh = *p_.keys[first].mesh;
    const std::vector<SurfacePoint> samples = sampleSurface(mesh, n, groupSeed(p_.sampleSeed, g));
    spacing_ = spacingOf(p_.keys[first]);
    tolerance_ = static_cast<float>(spacing_);
    keyFirst_ = first;
    keyLast_ = last;
    keyPos_.assign(last - first, {});
    for (std::size_t k = first; k < last; ++k) {
      std::vector<Vec3>& pos = keyPos_[k - first];
      pos.resize(n);
      const TriangleMesh& m = *p_.keys[k].mesh;
      parallelFor(n, [&](std::size_t i) { pos[i] = surfacePoint(m, samples[i]).cast<float>(); });
    }
    tSampling_ += since(t0);
  }

  // each insect (by id) to a sample of the group's first key, near-optimal in total distance
  void assignFrom(const SwarmState& s, double t) {
    const auto t0 = Clock::now();
    const std::size_t n = s.size();
    std::size_t a = 0, b = 0;
    float f = 0.0f;
    keyPair(t, a, b, f);
    // sample i's point now, as each step places them (placeTargets, with sample i in place i)
    std::vector<std::uint32_t> samples(n);
    std::iota(samples.begin(), samples.end(), 0u);
    std::vector<float> tx(n), ty(n), tz(n);
    if (n > 0) {
      const TargetPlacement placement = placementAt(t, a, b, f);
      parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
        placeTargets(placement, samples.data(), first, last - first, tx.data(), ty.data(), tz.data(), laneSet());
      });
    }
    std::vector<Vec3> agents(n), targets(n);
    parallelFor(n, [&](std::size_t i) {
      agents[s.id[i]] = s.position(i);
      targets[i] = Vec3(tx[i], ty[i], tz[i]);
    });
    assign_ = assignTargets(agents, targets);
    tAssignment_ += since(t0);
  }

  // the keys of the active group around time t and the fraction between them
  void keyPair(double t, std::size_t& a, std::size_t& b, float& f) const {
    a = b = 0;
    f = 0.0f;
    for (std::size_t k = keyFirst_; k + 1 < keyLast_; ++k) {
      if (t >= p_.keys[k].time) {
        a = k - keyFirst_;
        b = a + 1;
        const double span = p_.keys[k + 1].time - p_.keys[k].time;
        f = static_cast<float>(std::clamp((t - p_.keys[k].time) / span, 0.0, 1.0));
      }
    }
    if (keyLast_ - keyFirst_ == 1) b = a;
  }

  double pathDistance(double t) const {
    if (path_.empty()) return 0.0;
    return std::min(path_.length(), p_.path.speed * std::max(0.0, t - p_.path.start));
  }
  Vec3 pathShift(double t) const {
    if (path_.empty()) return Vec3::Zero();
    return path_.at(pathDistance(t)).cast<float>();
  }
  // rotation about z by the change of the path's heading since its start
  Eigen::Matrix3f pathRotation(double t) const {
    if (path_.empty() || !p_.path.turn) return Eigen::Matrix3f::Identity();
    const Vec3d a = path_.tangent(0.0), b = path_.tangent(pathDistance(t));
    const double yaw = std::atan2(b.y(), b.x()) - std::atan2(a.y(), a.x());
    return Eigen::AngleAxisd(yaw, Vec3d::UnitZ()).toRotationMatrix().cast<float>();
  }
  // the sample points at time t, keys a and b of the group with weight f on b: the placed mesh carried along the
  // path, C(s) + R (p − C(0)) (placeTargets, update_kernel.hpp)
  TargetPlacement placementAt(double t, std::size_t a, std::size_t b, float f) const {
    static_assert(sizeof(Vec3) == 3 * sizeof(float), "the samples' positions as x, y, z floats");
    const Eigen::Matrix3f rot = pathRotation(t);
    const Vec3 shift = pathShift(t), pivot = path_.empty() ? Vec3::Zero() : Vec3(path_.at(0.0).cast<float>());
    TargetPlacement placement;
    placement.keyA = keyPos_[a].front().data();
    placement.keyB = keyPos_[b].front().data();
    placement.samples = keyPos_[a].size();
    placement.f = f;
    placement.placed = !(shift == Vec3::Zero() && pivot == Vec3::Zero());
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) placement.rot[3 * r + c] = rot(r, c);
      placement.shift[r] = shift[r];
      placement.pivot[r] = pivot[r];
    }
    return placement;
  }
  // after a new assignment: no insect's sample is where last step left it, so the next step takes every
  // one through its id (last step's ids are what tells it where the state is as last step wrote it)
  void forgetSampleOrder() { ids_.clear(); }

  ShapeParams p_;
  Aabb domain_;
  Grid3<float> boundary_;  // obstacles and walls (the noise's blend)
  ObstacleClearance clearance_;
  NoiseField noise_;
  BSplinePath path_;
  InteractionForces forces_;
  UniformGrid grid_;
  double disRange_ = 1.0, spacing_ = 1.0;
  float tolerance_ = 1.0f;
  std::vector<std::size_t> groupStart_;
  std::int64_t group_ = -1;             // the active topology group (-1: before the first key)
  std::size_t keyFirst_ = 0, keyLast_ = 0;  // its keys
  std::vector<std::vector<Vec3>> keyPos_;   // per key of the group: sample positions (placed mesh)
  std::vector<std::uint32_t> assign_;       // insect id -> sample
  // per step, in grid order
  std::vector<float> vx_, vy_, vz_, fx_, fy_, fz_, tx_, ty_, tz_, nvx_, nvy_, nvz_;
  std::vector<float> tgx_, tgy_, tgz_;  // each insect's sample point this step
  std::vector<float> cnx_, cny_, cnz_;  // each insect's curl noise this step
  AlignedFloats rows_;                  // position and velocity rows (and a far row at n), cache-line aligned
  std::vector<std::uint32_t> ids_, lastIds_;        // ids by sorted position, this step's and last step's
  std::vector<std::uint32_t> sample_, lastSample_;  // the insects' samples (assign_) by sorted position, alike
  std::vector<NearScratch> scratch_;               // per thread: the near-field kernels' scratch
  // per state index (last step's sorted position), with the next step's in *Next_: the K nearest of last
  // step, as state indices (any K other insects bound the K-th distance: a bound only, never checkpointed),
  // how many there were, and the K-th one's distance (a search hint only)
  // this step's K-th distance (r_att if fewer) by sorted position, and last step's by state index
  std::vector<float> reach_, reachLast_;
  // by sorted position: this step's K nearest (sorted positions; kNone first when fewer than K), and by state
  // index last step's (their farthest now bounds the K-th distance: a search bound only, never checkpointed)
  std::vector<std::uint32_t> nearNext_, nearLast_;
  bool nearKept_ = false;                 // whether last step kept them (nearLast_ holds them)
  std::size_t keptSteps_ = 0;             // timed steps that bounded the search by them (a statistic)
  std::vector<std::uint32_t> newPos_;     // last step's sorted position (this step's state index) -> this step's
  NearLists lists_;                       // the near lists (near_list.hpp)
  // by sorted position: how many candidates within MDE's reach the near pass found (at the step's start), and
  // where they are: which thread's store (NearScratch::mde) and from where in it (their sorted positions, in id
  // order)
  struct MdeAt {
    std::uint32_t thread, first;
  };
  std::vector<std::uint32_t> mdeCount_;
  std::vector<MdeAt> mdeAt_;
  const std::uint32_t* mdeCandidates(std::size_t k) const {
    return scratch_[mdeAt_[k].thread].mde.data() + mdeAt_[k].first;
  }
  std::vector<float> move_;     // by sorted position: the move of this step (x, y, z)
  // per chunk: the bounding box of this step's moves and the largest squared move (min and max: the same
  // for any split), a cache line each
  struct alignas(64) MoveBox {
    float lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
    float move2 = 0.0f;
    float from[3] = {kInf, kInf, kInf}, to[3] = {-kInf, -kInf, -kInf};  // where the insects started
  };
  static constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<MoveBox> moveBox_;
  std::vector<float> relMax_;   // per chunk: the largest relative move
  std::vector<float> ownMove_;  // by sorted position: the move of this step relative to all (near lists)
  LocalMoveBound localBound_;   // and relative to the insects about it (near lists)
  std::vector<float> localMove_;
  int localPause_ = 0;        // steps to go without the local bound (it saved less than it cost)
  double builtRate_ = 0.0;    // lists built a step, smoothed
  float cellHint_ = 0.0f;     // the grid's smallest cell from the last step's K-th distances (checkpointed)
  std::vector<std::uint8_t> movedFlag_;
  std::vector<float> err_, speed_, sortScratch_;
  SwarmState next_;
  std::size_t frameMoved_ = 0, frameAgentSteps_ = 0, timedSteps_ = 0;
  double tDistance_ = 0.0, tNoise_ = 0.0, tSampling_ = 0.0, tAssignment_ = 0.0;
  std::size_t rebuilds_ = 0;  // near lists built from the grid in the timed steps
  double tLocal_ = 0.0;
  double tInteraction_ = 0.0, tForces_ = 0.0, tMde_ = 0.0, tGrid_ = 0.0, tNoiseStep_ = 0.0;
  // the grid's cells are kept across steps while the state stays in their order (see step)
  bool inGridOrder_ = false;
  double lastMaxMove_ = 0.0;           // the largest move of an insect last step (m, a little more)
  std::size_t gridBuilds_ = 0;         // grids built in the timed steps (a statistic)
  std::vector<std::uint32_t> identity_;  // 0, 1, ..., n - 1
};

}  // namespace

ShapeParams readShapeParams(JsonReader& r, const ModelContext& context) {
  ShapeParams p;
  p.alpha = r.number("alpha", p.alpha, Range::closed(0.0, 1.0));
  p.rRep = r.number("r_rep", p.rRep, Range::length());
  p.rAli = r.number("r_ali", p.rAli, Range::length());
  p.rAtt = r.number("r_att", p.rAtt, Range::length());
  if (!(p.rRep <= p.rAli)) r.fail("r_ali", "expected r_rep <= r_ali <= r_att");
  if (!(p.rAli <= p.rAtt)) r.fail("r_att", "expected r_rep <= r_ali <= r_att");
  const Range weight = Range::nonNegative().limited(0.0, kMaxForce);
  p.wRep = r.number("w_rep", p.wRep, weight);
  p.wAli = r.number("w_ali", p.wAli, weight);
  p.wAtt = r.number("w_att", p.wAtt, weight);
  p.neighbours = static_cast<int>(r.integer("neighbours", p.neighbours, 0, 10000));
  p.theta = r.number("far_field_theta", p.theta, Range::closed(0.0, 2.0));
  {
    JsonReader nz = r.object("noise", false);
    p.rho = nz.number("rho", p.rho, Range::length());
    checkNoiseFrequency(nz, "rho", context.world.domain, 1.0, 1.0 / p.rho);
    p.eta = nz.number("eta", p.eta, Range::nonNegative().limited(0.0, kMaxLength));
    readSeeds(nz, "seeds", p.seeds);
    p.noiseCells = readCells(nz, "cells", false, 2, 1024);
    nz.finish();
  }
  p.k = r.number("k", p.k, Range::positive().limited(1e-3, 1e3));
  p.omega = r.number("omega", p.omega, Range::positive().limited(1e-3, 1e3));
  p.wCon = r.number("w_con", p.wCon, weight);
  p.wDis = r.number("w_dis", p.wDis, weight);
  p.disRange = r.number("distance_range", p.disRange, Range::lengthOrZero());
  p.maxSpeed = r.number("max_speed", p.maxSpeed, Range::positiveSpeed());
  p.minDistance = r.number("min_distance", p.minDistance, Range::lengthOrZero());
  p.obstacleRange = r.number("obstacle_range", p.obstacleRange, Range::length());
  p.agentRadius = r.number("agent_radius", p.agentRadius, Range::lengthOrZero());
  p.sdfCells = readCells(r, "sdf_cells", false, 2, 1024);
  p.listSkin = r.number("list_skin", p.listSkin, Range::closed(0.0, 4.0));
  p.gridDrift = r.number("grid_drift", p.gridDrift, Range::closed(0.0, 2.0));
  p.sampleSeed = r.unsignedInteger("sample_seed", context.world.seed);
  p.count = context.count;

  double lastTime = -1.0;
  // targets: [{"time": t, "file": OBJ, "translate", "rotate", "scale"}, ...] with increasing times, or an
  // entry with "files": [OBJ, ...] and "interval": s (one key per file, `interval` apart, the list repeated
  // `repeat` times and closed by its first file again: a looping animation)
  std::vector<JsonReader> targets = r.objectArray("targets", true, 1);
  const auto addKey = [&](JsonReader& k, double time, const std::string& what, TriangleMesh mesh) {
    if (!(time > lastTime)) k.failExpected("time", "a time later than the previous target's", time);
    if (time > context.seconds) {
      k.failExpected("time", "a time within the run (0 to " + std::to_string(context.seconds) + " s)", time);
    }
    lastTime = time;
    ShapeKey key;
    key.time = time;
    const double area = surfaceArea(mesh);
    if (!(area > 0.0)) k.fail(what, mesh.source + ": the mesh has no area (every triangle is degenerate)");
    const bool same = !p.keys.empty() && sameTopology(mesh, *p.keys.back().mesh);
    if (!p.keys.empty() && k.boolean("animated", same)) {
      if (!same) {
        k.fail("animated", mesh.source + ": an animated target must have the previous target's vertex count and " +
                               "faces (" + std::to_string(mesh.vertices.size()) + " vertices and " +
                               std::to_string(mesh.triangles.size()) + " triangles, the previous " +
                               std::to_string(p.keys.back().mesh->vertices.size()) + " and " +
                               std::to_string(p.keys.back().mesh->triangles.size()) + ")");
      }
      key.sameTopology = true;
    }
    // section 5.1: neighbouring samples at least the insects' minimum distance apart; a mesh too small
    // for the swarm is scaled up about its centre (an animated sequence by its first key's factor and centre)
    const double spacing = std::sqrt(area / static_cast<double>(std::max<std::int64_t>(1, context.count)));
    Vec3d centre = mesh.bounds().center();
    if (key.sameTopology) {
      key.scaleUp = p.keys.back().scaleUp;
      centre = p.keys.back().scaleCentre;
    } else if (p.minDistance > 0.0 && spacing < p.minDistance) {
      key.scaleUp = p.minDistance / spacing;
      std::ostringstream msg;
      msg << mesh.source << ": scaled up " << key.scaleUp << " times so that " << context.count
          << " insects keep the minimum distance of " << p.minDistance << " m (" << k.pathOf(what) << ")";
      context.warnings.push_back(msg.str());
    }
    key.scaleCentre = centre;
    if (key.scaleUp != 1.0) {
      for (Vec3d& v : mesh.vertices) v = centre + key.scaleUp * (v - centre);
    }
    key.mesh = std::make_shared<const TriangleMesh>(std::move(mesh));
    p.keys.push_back(std::move(key));
  };
  for (JsonReader& k : targets) {
    const double t0 = k.number("time", 0.0, Range::nonNegative().limited(0.0, kMaxDuration));
    if (!k.has("files")) {
      addKey(k, t0, "file", readPlacedMesh(k, context.scenarioFile));
      k.finish();
      continue;
    }
    const Json* list = k.raw("files");
    std::vector<std::string> files;
    if (list && list->is_array()) {
      for (const Json& f : *list) {
        if (f.is_string() && !f.get<std::string>().empty()) files.push_back(f.get<std::string>());
      }
    }
    if (!list || !list->is_array() || list->empty() || files.size() != list->size()) {
      k.failExpected("files", "a non-empty array of OBJ file names", list ? *list : Json());
    }
    const double interval = k.requireNumber("interval", Range::duration());
    const std::int64_t repeat = k.integer("repeat", 1, 1, 100000);
    // each file placed as the entry says: read through a copy of the entry with "file" set
    std::vector<TriangleMesh> meshes;
    for (std::size_t i = 0; i < files.size(); ++i) {
      Json one = Json::object();
      for (const char* key : {"translate", "rotate", "scale"}) {
        if (const Json* v = k.raw(key)) one[key] = *v;
      }
      one["file"] = files[i];
      JsonReader single(one, k.file(), k.pathOf("files") + "[" + std::to_string(i) + "]", nullptr, k.inputs());
      meshes.push_back(readPlacedMesh(single, context.scenarioFile));
      files[i] = resolveInputPath(k.file(), files[i]);
    }
    k.resolve("files", files);
    for (std::int64_t rep = 0; rep < repeat; ++rep) {
      for (std::size_t i = 0; i < meshes.size(); ++i) {
        const double t = t0 + interval * static_cast<double>(rep * static_cast<std::int64_t>(meshes.size()) + i);
        addKey(k, t, "files", meshes[i]);
      }
    }
    addKey(k, t0 + interval * static_cast<double>(repeat * static_cast<std::int64_t>(meshes.size())), "files",
           meshes.front());
    k.finish();
  }
  if (r.has("path")) {
    JsonReader pr = r.object("path", false);
    const Json* pts = pr.raw("points");
    if (!pts || !pts->is_array()) pr.failMissing("points", "an array of at least 4 points [x, y, z]");
    if (pts->size() < BSplinePath::kDegree + 1) {
      pr.failExpected("points", "at least 4 control points (a cubic B-spline)", *pts);
    }
    for (std::size_t i = 0; i < pts->size(); ++i) {
      const Json& q = (*pts)[i];
      if (!q.is_array() || q.size() != 3 || !q[0].is_number() || !q[1].is_number() || !q[2].is_number()) {
        pr.failExpected("points", "points [x, y, z] of finite numbers (point " + std::to_string(i) + ")", *pts);
      }
      Vec3d v(q[0].get<double>(), q[1].get<double>(), q[2].get<double>());
      for (int a = 0; a < 3; ++a) {
        if (!(std::abs(v[a]) <= kMaxCoordinate)) {
          pr.failExpected("points", "coordinates within the limit (|x| <= 1e9) (point " + std::to_string(i) + ")", *pts);
        }
      }
      p.path.points.push_back(v);
    }
    pr.resolve("points", *pts);
    p.path.speed = pr.number("speed", p.path.speed, Range::speed());
    p.path.start = pr.number("start", p.path.start, Range::nonNegative().limited(0.0, kMaxDuration));
    p.path.turn = pr.boolean("turn", p.path.turn);
    pr.finish();
  }
  return p;
}

std::shared_ptr<const ModelConfig> parseShape(JsonReader& params, const ModelContext& context) {
  return std::make_shared<ShapeConfig>(readShapeParams(params, context));
}

std::unique_ptr<Model> makeShape(const ShapeParams& params, const World& world) {
  return std::make_unique<ShapeModel>(params, world);
}

}  // namespace swarmsim
