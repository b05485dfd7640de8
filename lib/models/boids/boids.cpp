#include "models/boids/boids.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "core/lanes.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "core/rng_lanes.hpp"
#include "models/boids/boids_kernel.hpp"
#include "models/boids/boids_update.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace {

class BoidsConfig final : public ModelConfig {
 public:
  explicit BoidsConfig(const BoidsParams& p) : p_(p) {}
  std::unique_ptr<Model> build(const World&) const override { return makeBoids(p_); }

 private:
  BoidsParams p_;
};

class Boids final : public Model {
 public:
  explicit Boids(const BoidsParams& p) : p_(p) {
    r1_ = static_cast<float>(p.repulsionZone);
    r2_ = static_cast<float>(p.repulsionZone + p.alignmentZone);
    r3_ = static_cast<float>(p.repulsionZone + p.alignmentZone + p.attractionZone);
    cosHalfFov_ = static_cast<float>(std::cos(0.5 * p.fieldOfView * M_PI / 180.0));
  }

  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    const std::size_t n = s.size();
    // the grid (one rebuild per step), then the state put in its cell order (the kernel reads the positions
    // in place: the grid keeps no copy) and the unit velocities in that order
    grid_.build(s.px.data(), s.py.data(), s.pz.data(), n, r3_, 2.0, false);
    putInCellOrder(s);
    lanes_.prepare(s.px.data(), s.py.data(), s.pz.data(), n);
    const LaneSet laneKind = laneSet();
    parallelChunks(n, [&](std::size_t first, std::size_t last, int) {
      unitVelocities(s.vx.data() + first, s.vy.data() + first, s.vz.data() + first, last - first,
                     lanes_.ux.data() + first, lanes_.uy.data() + first, lanes_.uz.data() + first, laneKind);
    });

    const float dt = static_cast<float>(world.dt);
    // the update's parameters (boids_update.hpp)
    const double alpha = p_.responseTime > 0.0 ? 1.0 - std::exp(-world.dt / p_.responseTime) : 1.0;
    BoidsUpdateParams up;
    up.smin = static_cast<float>(p_.speed);
    up.smax = static_cast<float>(p_.maxSpeed);
    up.fr = static_cast<float>(p_.repulsion);
    up.fa = static_cast<float>(p_.alignment);
    up.ft = static_cast<float>(p_.attraction);
    up.fc = static_cast<float>(p_.centering);
    up.invCr = p_.centeringRadius > 0.0 ? static_cast<float>(1.0 / p_.centeringRadius) : 0.0f;
    up.fw = static_cast<float>(p_.wallForce);
    up.margin = static_cast<float>(p_.wallMargin);
    up.blend = static_cast<float>(alpha);
    up.noise = static_cast<float>(p_.jitter * std::sqrt((2.0 - alpha) / alpha));
    up.center = p_.center.cast<float>();
    up.lo = world.domain.min.cast<float>();
    up.hi = world.domain.max.cast<float>();

    // phase 1: the neighbour sums of a row of cells (boids_kernel.hpp), then phase 2: the row's new velocities,
    // in place (neighbours read the unit velocities' copy), eight agents at a time (boids_update.hpp)
    const BoidsZones zones = {r1_ * r1_, r2_ * r2_, r3_ * r3_, cosHalfFov_};
    const bool jitter = p_.jitter > 0.0;
    const std::uint64_t seed = world.seed, stepIndex = info.step;
    const std::uint32_t swarmIndex = info.swarmIndex;
    scratch_.resize(static_cast<std::size_t>(threadCount()));
    const std::size_t nx = static_cast<std::size_t>(grid_.dim(0));
    // row by row of cells (the neighbouring rows found once per row), cell by cell along it; a row's agents are
    // the sorted positions [first, last)
    const auto row = [&](std::size_t rowIndex) {
      BoidsScratch& scratch = scratch_[static_cast<std::size_t>(threadIndex())];
      const std::uint32_t first = grid_.cellBegin(rowIndex * nx), last = grid_.cellEnd(rowIndex * nx + nx - 1);
      if (first == last) return;
      const std::size_t m = last - first;
      if (scratch.sums.size() < 9 * m) scratch.sums.resize(18 * m);
      float* sums[9];
      for (std::size_t a = 0; a < 9; ++a) sums[a] = scratch.sums.data() + a * m;
      grid_.forEachCellOfRow(rowIndex, r3_, scratch.runs, [&](std::size_t c, const std::uint32_t* runs, std::size_t nRuns) {
        const std::uint32_t a0 = grid_.cellBegin(c), a1 = grid_.cellEnd(c);
        float* at[9];
        for (std::size_t a = 0; a < 9; ++a) at[a] = sums[a] + (a0 - first);
        boidsCellSums(lanes_, a0, a1, runs, nRuns, zones, laneKind, scratch, at);
      });
      // the jitter's four uniforms of each agent, from its own stream (by id: the same draw on any thread)
      float* draws[4] = {nullptr, nullptr, nullptr, nullptr};
      if (jitter) {
        if (scratch.jitter.size() < 4 * m) scratch.jitter.resize(8 * m);
        for (std::size_t w = 0; w < 4; ++w) draws[w] = scratch.jitter.data() + w * m;
        firstUniforms(seed, stepIndex, s.id.data() + first, m, RngPurpose::kJitter, swarmIndex, draws, laneKind);
      }
      const BoidsUpdateRow r = {s.px.data() + first,
                                s.py.data() + first,
                                s.pz.data() + first,
                                lanes_.ux.data() + first,
                                lanes_.uy.data() + first,
                                lanes_.uz.data() + first,
                                s.vx.data() + first,
                                s.vy.data() + first,
                                s.vz.data() + first,
                                {sums[0], sums[1], sums[2], sums[3], sums[4], sums[5], sums[6], sums[7], sums[8]},
                                {draws[0], draws[1], draws[2], draws[3]}};
      boidsUpdate(r, m, up, laneKind);
    };
    // each agent's work is a whole neighbourhood scan: worth the team from a few hundred agents on
    const std::size_t rows = grid_.rowCount();
    if (n < 256) {
      for (std::size_t r = 0; r < rows; ++r) row(r);
    } else {
      parallelForDynamic(rows, std::clamp<std::size_t>(rows / (16 * scratch_.size()), 1, 16), row);
    }
    // phase 3: the moves, once no neighbour reads the old positions
    parallelFor(n, [&](std::size_t k) {
      s.px[k] += s.vx[k] * dt;
      s.py[k] += s.vy[k] * dt;
      s.pz[k] += s.vz[k] * dt;
    });
  }

 private:
  BoidsParams p_;
  float r1_, r2_, r3_, cosHalfFov_;
  UniformGrid grid_;
  // the whole state in the grid's cell order, with no second copy of it (docs/performance.md#memory): three
  // arrays at a time gathered into the unit velocities' arrays (not yet written this step), which then swap
  // with them; the ids through one of them. A state kept in last step's order is nearly in this one, so the
  // reads are nearly in sequence.
  void putInCellOrder(SwarmState& s) {
    const std::size_t n = s.size();
    const auto& order = grid_.order();
    std::array<std::vector<float>*, 3> buf = {&lanes_.ux, &lanes_.uy, &lanes_.uz};
    for (auto* b : buf) b->resize(n);
    const std::array<std::array<std::vector<float>*, 3>, 2> groups = {{{&s.px, &s.py, &s.pz}, {&s.vx, &s.vy, &s.vz}}};
    for (const auto& three : groups) {
      parallelFor(n, [&](std::size_t k) {
        const std::uint32_t i = order[k];
        for (int c = 0; c < 3; ++c) (*buf[c])[k] = (*three[c])[i];
      });
      for (int c = 0; c < 3; ++c) {
        three[c]->swap(*buf[c]);
      }
    }
    float* t = lanes_.ux.data();
    parallelFor(n, [&](std::size_t k) { std::memcpy(t + k, &s.id[order[k]], sizeof(float)); });
    parallelFor(n, [&](std::size_t k) { std::memcpy(&s.id[k], t + k, sizeof(float)); });
  }

  // scratch, reused every step (no allocation once sized)
  BoidsLanesInput lanes_;  // the state's positions (in place) and unit velocities, in cell order
  std::vector<BoidsScratch> scratch_;  // per thread
};

}  // namespace

BoidsParams readBoidsParams(JsonReader& r, const ModelContext& context) {
  BoidsParams p;
  // limits: docs/scenario.md#limits (speeds and the velocity weights at most kMaxSpeed, lengths kMaxLength)
  p.speed = r.number("speed", p.speed, Range::positiveSpeed());
  p.maxSpeed = r.number("max_speed", std::max(p.maxSpeed, p.speed), Range::positiveSpeed());
  if (p.maxSpeed < p.speed) r.fail("max_speed", "expected a number >= speed (" + std::to_string(p.speed) + ")");
  p.repulsionZone = r.number("repulsion_zone", p.repulsionZone, Range::lengthOrZero());
  p.alignmentZone = r.number("alignment_zone", p.alignmentZone, Range::lengthOrZero());
  p.attractionZone = r.number("attraction_zone", p.attractionZone, Range::lengthOrZero());
  if (!(p.repulsionZone + p.alignmentZone + p.attractionZone > 0.0)) {
    r.fail("attraction_zone", "the three zone widths add up to 0; expected a positive outer radius");
  }
  p.fieldOfView = r.number("field_of_view", p.fieldOfView, Range::closed(0.0, 360.0));
  p.repulsion = r.number("repulsion", p.repulsion, Range::speed());
  p.alignment = r.number("alignment", p.alignment, Range::speed());
  p.attraction = r.number("attraction", p.attraction, Range::speed());
  p.centering = r.number("centering", p.centering, Range::speed());
  p.centeringRadius = r.number("centering_radius", p.centeringRadius, Range::lengthOrZero());
  p.center = r.vec3("center", context.world.domain.center(), Range::coordinate());
  const Vec3d ext = context.world.domain.extent();
  p.wallMargin = r.number("wall_margin", std::max(kMinLength, 0.1 * ext.minCoeff()), Range::length());
  p.wallForce = r.number("wall_force", p.wallForce, Range::speed());
  p.jitter = r.number("jitter", p.jitter, Range::speed());
  // 0 (instant) or at most kMaxDuration: with dt >= kMinDt the blend 1 - exp(-dt / response_time) stays > 0 in
  // double precision (dt / response_time >= 1e-15), else the noise term sqrt((2 - a) / a) would be Inf
  p.responseTime = r.number("response_time", p.responseTime, Range::nonNegative().limited(0.0, kMaxDuration));
  return p;
}

std::shared_ptr<const ModelConfig> parseBoids(JsonReader& params, const ModelContext& context) {
  return std::make_shared<BoidsConfig>(readBoidsParams(params, context));
}

std::unique_ptr<Model> makeBoids(const BoidsParams& params) { return std::make_unique<Boids>(params); }

}  // namespace swarmsim
