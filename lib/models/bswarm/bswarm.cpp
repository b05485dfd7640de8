#include "models/bswarm/bswarm.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "fields/curl_noise.hpp"
#include "fields/noise_field.hpp"
#include "fields/grid3.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/bswarm/interaction.hpp"
#include "models/params_util.hpp"
#include "orca/orca.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kPi = 3.14159265358979323846;

std::string dimsText(const std::array<int, 3>& n) {
  return std::to_string(n[0]) + "x" + std::to_string(n[1]) + "x" + std::to_string(n[2]);
}

StimulusSpec::Kind readKind(JsonReader& r) {
  const std::string type = r.choice("type", "", {"predator", "attractor"});
  if (type.empty()) r.failMissing("type", "\"predator\" (escape) or \"attractor\" (pursuit)");
  return type == "predator" ? StimulusSpec::Kind::kPredator : StimulusSpec::Kind::kAttractor;
}

Vec3d readAxis(JsonReader& r, const std::string& key, const Vec3d& fallback) {
  const Vec3d a = r.vec3(key, fallback, Range::coordinate());  // bounded: the squared norm stays finite
  if (!(a.norm() > 0.0)) r.fail(key, "expected a non-zero vector");
  return a.normalized();
}

// the parameters a schedule may set, by their scenario names
struct DynamicField {
  const char* name;
  double BswarmDynamic::*field;
  Range range;
};
// Limits (docs/scenario.md#limits): forces (m/s^2) and γ at most kMaxForce, so that they and
// γ |v| v (|v| <= kMaxSpeed) stay finite in float; the zone radii at most kMaxZone: the
// interaction's neighbour grid has cells of at least 1e-4 m and a zone may span at most
// 1e9 cells (an int)
constexpr double kMaxForce = 1e9;
constexpr double kMaxZone = 1e5;
const std::vector<DynamicField>& dynamicFields() {
  static const std::vector<DynamicField> fields = {
      {"gamma", &BswarmDynamic::gamma, Range::nonNegative().limited(0.0, kMaxForce)},
      {"gain", &BswarmDynamic::gain, Range::nonNegative().limited(0.0, kMaxForce)},
      {"lambda_rep", &BswarmDynamic::lambdaRep, Range::nonNegative().limited(0.0, kMaxForce)},
      {"lambda_ali", &BswarmDynamic::lambdaAli, Range::nonNegative().limited(0.0, kMaxForce)},
      {"lambda_att", &BswarmDynamic::lambdaAtt, Range::nonNegative().limited(0.0, kMaxForce)},
      {"r_rep", &BswarmDynamic::rRep, Range::positive().limited(kMinLength, kMaxZone)},
      {"r_ali", &BswarmDynamic::rAli, Range::positive().limited(kMinLength, kMaxZone)},
      {"r_att", &BswarmDynamic::rAtt, Range::positive().limited(kMinLength, kMaxZone)},
      {"lambda_res", &BswarmDynamic::lambdaRes, Range::nonNegative().limited(0.0, kMaxForce)},
      {"r_res", &BswarmDynamic::rRes, Range::nonNegative().limited(0.0, kMaxLength)},
  };
  return fields;
}
const Range& rangeOf(const char* name) {
  for (const auto& f : dynamicFields()) {
    if (std::string(f.name) == name) return f.range;
  }
  throw std::logic_error(std::string("bswarm: no dynamic parameter ") + name);
}

// rotate v about the unit axis n by angle (radians), Rodrigues
Vec3 rotate(const Vec3& v, const Vec3& n, float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  return v * c + n.cross(v) * s + n * (n.dot(v) * (1.0f - c));
}

class BswarmConfig final : public ModelConfig {
 public:
  explicit BswarmConfig(const BswarmParams& p) : p_(p) {}
  std::unique_ptr<Model> build(const World& world) const override { return makeBswarm(p_, world); }

 private:
  BswarmParams p_;
};

class BswarmModel final : public Model {
 public:
  BswarmModel(const BswarmParams& p, const World& world) : p_(p), domain_(world.domain) {
    const Obstacles& obs = *world.obstacles;
    const auto t0 = Clock::now();
    // distance to obstacles and domain walls, for ORCA's obstacle constraints
    sdfSpec_ = GridSpec::covering(
        domain_.min, domain_.max,
        p_.sdfCells[0] > 0 ? p_.sdfCells : cellsForEdge(domain_, domain_.extent().maxCoeff() / 128.0, 4e6));
    sdf_ = signedDistance(obs, sdfSpec_);
    addBoxWalls(sdf_, domain_);
    tDistance_ = since(t0);

    const auto t1 = Clock::now();
    if (p_.noise == BswarmNoise::kCurl || p_.noise == BswarmNoise::kPerlin) {
      NoiseParams np;
      np.scale = p_.scale;
      np.gain = 1.0;  // the (scheduled) gain multiplies the sampled field
      np.seeds = p_.seeds;
      np.unit = p_.noiseUnit;  // scale: lattice cells per noise unit
      np.d0 = 0.5 * p_.noiseUnit / p_.scale;
      noise_ = NoiseField(p_.noise == BswarmNoise::kCurl ? NoiseFieldKind::kCurl : NoiseFieldKind::kPerlin, np,
                          domain_, obs, p_.noiseCells, &sdf_);
    }
    tNoise_ = since(t1);

    orcaParams_.radius = static_cast<float>(p_.radius);
    orcaParams_.neighborDistance = static_cast<float>(p_.neighborDistance);
    orcaParams_.maxNeighbors = p_.maxNeighbors;
    orcaParams_.timeHorizon = static_cast<float>(p_.timeHorizon);
    orcaParams_.timeHorizonObstacle = static_cast<float>(p_.timeHorizonObstacle);
    orcaParams_.maxSpeed = static_cast<float>(p_.maxSpeed);
    orcaObstacles_.sdf = &sdf_;
    // escape angles are needed only when something can be escaped from
    needEscapeAngle_ = p_.attached.enabled && p_.attached.kind == StimulusSpec::Kind::kPredator;
    for (const auto& st : p_.stimuli) needEscapeAngle_ = needEscapeAngle_ || st.kind == StimulusSpec::Kind::kPredator;
  }

  std::vector<std::string> statNames() const override {
    return {"polarisation", "stimulus_distance", "infeasible_fraction"};
  }

  void takeFrameStats(std::vector<double>& values) override {
    values = {
        lastPolarisation_, lastStimulusDistance_,
        frameAgentSteps_ > 0 ? static_cast<double>(frameInfeasible_) / static_cast<double>(frameAgentSteps_) : 0.0};
    frameInfeasible_ = frameAgentSteps_ = 0;
  }

  Json benchInfo() const override {
    const char* noise = p_.noise == BswarmNoise::kCurl     ? "curl"
                        : p_.noise == BswarmNoise::kPerlin ? "perlin"
                        : p_.noise == BswarmNoise::kWhite  ? "white"
                                                           : "gaussian";
    // timings per agent-step, after the first step (which sizes every buffer)
    const double steps = static_cast<double>(std::max<std::size_t>(1, timedAgentSteps_));
    // the far field's work per agent evaluated (docs/performance.md: its flops)
    const InteractionForces::Work& far = forces_.work();
    const double farAgents = static_cast<double>(std::max<std::uint64_t>(1, far.agents));
    return {{"noise", noise},
            {"far_agent_entries", static_cast<double>(far.agentEntries) / farAgents},
            {"far_pseudo_entries", static_cast<double>(far.pseudoEntries) / farAgents},
            {"far_cut_cells", static_cast<double>(far.cuts) / farAgents},
            {"noise_grid", noise_.direct()                                                      ? "direct"
                           : p_.noise == BswarmNoise::kCurl || p_.noise == BswarmNoise::kPerlin ? dimsText(noise_.spec().n)
                                                                                                : "-"},
            {"sdf_grid", dimsText(sdfSpec_.n)},
            {"t_distance", tDistance_},
            {"t_noise", tNoise_},
            {"theta", p_.theta},
            {"ns_grid", 1e9 * tGrid_ / steps},
            {"ns_forces", 1e9 * tForces_ / steps},
            {"ns_orca_neighbours", 1e9 * tOrcaNeighbours_ / steps},
            {"ns_orca_lp", 1e9 * tOrcaLp_ / steps},
            {"ns_orca", 1e9 * (tOrcaNeighbours_ + tOrcaLp_) / steps},
            {"infeasible_percent", 100.0 * static_cast<double>(totalInfeasible_) /
                                       static_cast<double>(std::max<std::size_t>(1, totalAgentSteps_))}};
  }

  // carried between steps: only statistics (stimulus paths, schedules and the
  // escape angles follow from the time, the parameters and the random streams)
  void saveState(StateOut& out) const override {
    out.put(lastPolarisation_);
    out.put(lastStimulusDistance_);
    for (std::size_t v : {frameInfeasible_, frameAgentSteps_, totalInfeasible_, totalAgentSteps_, timedAgentSteps_}) {
      out.put<std::uint64_t>(v);
    }
    solver_.saveState(out);
  }

  void loadState(StateIn& in, const World&) override {
    lastPolarisation_ = in.get<double>();
    lastStimulusDistance_ = in.get<double>();
    for (std::size_t* v :
         {&frameInfeasible_, &frameAgentSteps_, &totalInfeasible_, &totalAgentSteps_, &timedAgentSteps_}) {
      *v = static_cast<std::size_t>(in.get<std::uint64_t>());
    }
    solver_.loadState(in);
  }

  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    const std::size_t n = s.size();
    const double t = info.time;
    const float dt = static_cast<float>(world.dt);
    BswarmDynamic d = p_.dyn;
    p_.schedule.apply(t, d);
    d.rAli = std::max(d.rAli, d.rRep);
    d.rAtt = std::max(d.rAtt, d.rAli);

    // one grid per step: ORCA's neighbours and the interaction forces both use it
    auto t0 = Clock::now();
    // cells as ORCA's k-nearest search wants them, so it searches this grid rather than building its own
    grid_.build(s.px.data(), s.py.data(), s.pz.data(), n, std::max(solver_.suggestedCell(orcaParams_), 1e-4f));
    const auto& order = grid_.order();
    for (auto* a : {&vx_, &vy_, &vz_, &fx_, &fy_, &fz_, &wx_, &wy_, &wz_, &ox_, &oy_, &oz_}) a->resize(n);
    ids_.resize(n);
    parallelFor(n, [&](std::size_t k) {
      const std::uint32_t i = order[k];
      vx_[k] = s.vx[i];
      vy_[k] = s.vy[i];
      vz_[k] = s.vz[i];
      ids_[k] = s.id[i];
    });
    tGrid_ += since(t0);

    // F_int (eq. 4)
    const ZoneParams zones = ZoneParams::of(d.rRep, d.rAli, d.rAtt, d.lambdaRep, d.lambdaAli, d.lambdaAtt);
    t0 = Clock::now();
    forces_.compute(grid_, vx_.data(), vy_.data(), vz_.data(), zones, static_cast<float>(p_.theta), fx_.data(),
                    fy_.data(), fz_.data());
    tForces_ += since(t0);

    // stimuli at this time
    stimulusCenters_.resize(p_.stimuli.size());
    orcaObstacles_.spheres.clear();
    for (std::size_t e = 0; e < p_.stimuli.size(); ++e) {
      stimulusCenters_[e] = p_.stimuli[e].path.at(t).cast<float>();
      if (p_.stimuli[e].solid && p_.stimuli[e].radius > 0.0) {
        // its velocity over this step: ORCA avoids it in relative velocity
        const Vec3d velocity = (p_.stimuli[e].path.at(t + world.dt) - p_.stimuli[e].path.at(t)) / world.dt;
        orcaObstacles_.spheres.push_back(
            {stimulusCenters_[e], static_cast<float>(p_.stimuli[e].radius), velocity.cast<float>()});
      }
    }

    // preferred velocities: v + a dt (unit mass)
    const float* sx = grid_.sortedX().data();
    const float* sy = grid_.sortedY().data();
    const float* sz = grid_.sortedZ().data();
    const float gamma = static_cast<float>(d.gamma), gain = static_cast<float>(d.gain);
    const float lambdaRes = static_cast<float>(d.lambdaRes), rRes = static_cast<float>(d.rRes);
    const float thetaMin = static_cast<float>(p_.escapeAngleMin * kPi / 180.0);
    const float thetaMax = static_cast<float>(p_.escapeAngleMax * kPi / 180.0);
    ResponseInputs response;
    response.lambdaRes = lambdaRes;
    response.rRes = rRes;
    response.stimuli = &p_.stimuli;
    response.centers = stimulusCenters_.data();
    response.attached = &p_.attached;
    response.escapeAxis = p_.escapeAxis.cast<float>();

    parallelFor(n, [&](std::size_t k) {
      const Vec3 x(sx[k], sy[k], sz[k]);
      const Vec3 v(vx_[k], vy_[k], vz_[k]);
      Vec3 a(fx_[k], fy_[k], fz_[k]);
      a += frictionForce(v, gamma);
      if (lambdaRes > 0.0f && (!p_.stimuli.empty() || p_.attached.enabled)) {
        // each insect escapes along its own fixed rotation of the away direction ("a determined direction")
        float theta = 0.0f;
        if (needEscapeAngle_) {
          AgentRng rng(world.seed, 0, ids_[k], RngPurpose::kEscape, info.swarmIndex);
          theta = rng.uniform(thetaMin, thetaMax);
        }
        a += responseForce(response, x, v, theta);
      }
      switch (p_.noise) {
        case BswarmNoise::kCurl:
        case BswarmNoise::kPerlin:
          a += noise_(x) * gain;
          break;
        case BswarmNoise::kWhite: {
          AgentRng rng(world.seed, info.step, ids_[k], RngPurpose::kNoise, info.swarmIndex);
          a += Vec3(rng.uniform(-1.0f, 1.0f), rng.uniform(-1.0f, 1.0f), rng.uniform(-1.0f, 1.0f)) * gain;
          break;
        }
        case BswarmNoise::kGaussian: {
          AgentRng rng(world.seed, info.step, ids_[k], RngPurpose::kNoise, info.swarmIndex);
          a += rng.normal3() * gain;
          break;
        }
      }
      const Vec3 pref = v + a * dt;
      wx_[k] = pref.x();
      wy_[k] = pref.y();
      wz_[k] = pref.z();
    });

    // ORCA: collision-free velocities closest to the preferred ones
    solver_.solve(grid_, vx_.data(), vy_.data(), vz_.data(), wx_.data(), wy_.data(), wz_.data(), orcaParams_,
                  orcaObstacles_, dt, ox_.data(), oy_.data(), oz_.data());
    tOrcaNeighbours_ += solver_.neighbourSeconds();
    tOrcaLp_ += solver_.lpSeconds();
    frameInfeasible_ += solver_.infeasibleCount();
    totalInfeasible_ += solver_.infeasibleCount();

    // move; the state is rewritten in grid order (spatial sorting)
    next_.resizeStorage(n);
    const Vec3 lo = domain_.min.cast<float>(), hi = domain_.max.cast<float>();
    parallelFor(n, [&](std::size_t k) {
      const Vec3 v(ox_[k], oy_[k], oz_[k]);
      const Vec3 x = (Vec3(sx[k], sy[k], sz[k]) + v * dt).cwiseMax(lo).cwiseMin(hi);
      next_.px[k] = x.x();
      next_.py[k] = x.y();
      next_.pz[k] = x.z();
      next_.vx[k] = v.x();
      next_.vy[k] = v.y();
      next_.vz[k] = v.z();
      next_.id[k] = ids_[k];
    });
    s.swapStorage(next_);

    lastPolarisation_ = polarisation(s.vx.data(), s.vy.data(), s.vz.data(), n, &polarParts_);
    lastStimulusDistance_ = nearestToStimulus(s);
    frameAgentSteps_ += n;
    if (totalAgentSteps_ == 0) {
      tGrid_ = tForces_ = tOrcaNeighbours_ = tOrcaLp_ = 0.0;  // the first step is not timed
    } else {
      timedAgentSteps_ += n;
    }
    totalAgentSteps_ += n;
  }

  void restartBenchTimers() override {
    tGrid_ = tForces_ = tOrcaNeighbours_ = tOrcaLp_ = 0.0;
    timedAgentSteps_ = 0;
  }

 private:
  // distance from the first stimulus's surface to the nearest insect (NaN without stimuli); min is exact in any order
  double nearestToStimulus(const SwarmState& s) {
    if (p_.stimuli.empty() || s.size() == 0) return std::numeric_limits<double>::quiet_NaN();
    const Vec3 c = stimulusCenters_[0];
    std::vector<float>& part = nearestParts_;  // kept between steps
    part.assign(static_cast<std::size_t>(chunkCount(s.size())), std::numeric_limits<float>::infinity());
    parallelChunks(s.size(), [&](std::size_t first, std::size_t last, int chunk) {
      float m = std::numeric_limits<float>::infinity();
      for (std::size_t i = first; i < last; ++i) m = std::min(m, (s.position(i) - c).squaredNorm());
      part[static_cast<std::size_t>(chunk)] = m;
    });
    const float m2 = *std::min_element(part.begin(), part.end());
    return std::max(0.0, std::sqrt(static_cast<double>(m2)) - p_.stimuli[0].radius);
  }

  BswarmParams p_;
  Aabb domain_;
  GridSpec sdfSpec_;
  Grid3<float> sdf_;     // obstacles and walls, for ORCA
  NoiseField noise_;     // curl noise (or Perlin) with gain 1
  bool needEscapeAngle_ = false;
  orca::Params orcaParams_;
  orca::Obstacles orcaObstacles_;
  orca::Solver solver_;
  InteractionForces forces_;
  UniformGrid grid_;
  std::vector<float> vx_, vy_, vz_, fx_, fy_, fz_, wx_, wy_, wz_, ox_, oy_, oz_;  // sorted order
  std::vector<std::uint32_t> ids_;
  std::vector<Vec3> stimulusCenters_;
  std::vector<float> nearestParts_;
  std::vector<Vec3d> polarParts_;
  SwarmState next_;
  double tDistance_ = 0.0, tNoise_ = 0.0;
  double tGrid_ = 0.0, tForces_ = 0.0, tOrcaNeighbours_ = 0.0, tOrcaLp_ = 0.0;
  // before the first step: not computed
  double lastPolarisation_ = std::numeric_limits<double>::quiet_NaN();
  double lastStimulusDistance_ = std::numeric_limits<double>::quiet_NaN();
  std::size_t frameInfeasible_ = 0, frameAgentSteps_ = 0, totalInfeasible_ = 0, totalAgentSteps_ = 0;
  std::size_t timedAgentSteps_ = 0;
};

}  // namespace

Vec3 frictionForce(const Vec3& v, float gamma) { return v * (-gamma * v.norm()); }

Vec3 responseForce(const ResponseInputs& in, const Vec3& x, const Vec3& v, float theta) {
  Vec3 a = Vec3::Zero();
  // r̂ points from the stimulus to the insect: escape along R(n, θ) r̂, pursue along -r̂
  const auto respond = [&](StimulusSpec::Kind kind, const Vec3& away, float weight) {
    a += kind == StimulusSpec::Kind::kPredator ? rotate(away, in.escapeAxis, theta) * (in.lambdaRes * weight)
                                               : away * (-in.lambdaRes * weight);
  };
  for (std::size_t e = 0; e < in.stimuli->size(); ++e) {
    const StimulusSpec& st = (*in.stimuli)[e];
    const Vec3 rel = x - in.centers[e];
    const float dist = rel.norm();
    const float range = st.visualRange >= 0.0 ? static_cast<float>(st.visualRange) : in.rRes;
    // H(r_res - r_ie), r_ie to the centre of a point, to the surface of a sphere
    if (std::max(0.0f, dist - static_cast<float>(st.radius)) > range || !(dist > 0.0f)) continue;
    respond(st.kind, rel / dist, static_cast<float>(st.weight));
  }
  const AttachedStimulus& at = *in.attached;
  if (at.enabled && static_cast<float>(at.distance) <= in.rRes) {
    const float speed = v.norm();
    const Vec3 heading = speed > 0.0f ? Vec3(v / speed) : Vec3(Vec3::UnitX());
    const Vec3 ahead = rotate(heading, at.axis.cast<float>(), static_cast<float>(at.angle * kPi / 180.0));
    respond(at.kind, -ahead, static_cast<float>(at.weight));
  }
  return a;
}

void BswarmSchedule::apply(double t, BswarmDynamic& d) const {
  for (const Track& tr : tracks) {
    const double v = interpolateKeys(tr.times, tr.values, t);
    for (const auto& field : dynamicFields()) {
      if (tr.name == field.name) d.*(field.field) = v;
    }
  }
}

double polarisation(const float* vx, const float* vy, const float* vz, std::size_t n, std::vector<Vec3d>* scratch) {
  if (n == 0) return 0.0;
  // fixed blocks of 4,096 agents summed in block order: the same for any thread count
  constexpr std::size_t kBlock = 4096;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<Vec3d> local;
  std::vector<Vec3d>& part = scratch ? *scratch : local;
  part.assign(blocks, Vec3d::Zero());
  const auto blockSum = [&](std::size_t b) {
    Vec3d sum = Vec3d::Zero();
    for (std::size_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      const Vec3d v(vx[i], vy[i], vz[i]);
      const double len = v.norm();
      if (len > 0.0) sum += v / len;
    }
    part[b] = sum;
  };
  if (blocks == 1) {  // a small swarm: not worth waking the team
    blockSum(0);
  } else {
    parallelForDynamic(blocks, 1, blockSum);
  }
  Vec3d total = Vec3d::Zero();
  for (const Vec3d& p : part) total += p;
  return total.norm() / static_cast<double>(n);
}

BswarmParams readBswarmParams(JsonReader& r, const ModelContext& context) {
  BswarmParams p;
  BswarmDynamic& d = p.dyn;
  // the same ranges as in a schedule (dynamicFields)
  d.gamma = r.number("gamma", d.gamma, rangeOf("gamma"));
  d.lambdaRep = r.number("lambda_rep", d.lambdaRep, rangeOf("lambda_rep"));
  d.lambdaAli = r.number("lambda_ali", d.lambdaAli, rangeOf("lambda_ali"));
  d.lambdaAtt = r.number("lambda_att", d.lambdaAtt, rangeOf("lambda_att"));
  d.lambdaRes = r.number("lambda_res", d.lambdaRes, rangeOf("lambda_res"));
  d.rRes = r.number("r_res", d.rRes, rangeOf("r_res"));
  // radii: absolute (r_ali, r_att) or, as in the paper's Table 1, differences (dr_ali = r_ali - r_rep, dr_att = r_att -
  // r_ali)
  d.rRep = r.number("r_rep", d.rRep, rangeOf("r_rep"));
  if (r.has("r_ali") && r.has("dr_ali")) r.fail("dr_ali", "give r_ali (absolute) or dr_ali (r_ali - r_rep), not both");
  if (r.has("r_att") && r.has("dr_att")) r.fail("dr_att", "give r_att (absolute) or dr_att (r_att - r_ali), not both");
  if (r.has("dr_ali")) {
    d.rAli = d.rRep + r.requireNumber("dr_ali", Range::nonNegative().limited(0.0, kMaxZone));
    if (!rangeOf("r_ali").contains(d.rAli))
      r.fail("dr_ali", "expected r_rep + dr_ali to be " + rangeOf("r_ali").describe());
  } else {
    d.rAli = r.number("r_ali", d.rRep, rangeOf("r_ali"));
    if (d.rAli < d.rRep) r.fail("r_ali", "expected r_ali >= r_rep (" + std::to_string(d.rRep) + ")");
  }
  if (r.has("dr_att")) {
    d.rAtt = d.rAli + r.requireNumber("dr_att", Range::nonNegative().limited(0.0, kMaxZone));
    if (!rangeOf("r_att").contains(d.rAtt))
      r.fail("dr_att", "expected r_ali + dr_att to be " + rangeOf("r_att").describe());
  } else {
    d.rAtt = r.number("r_att", std::max(d.rAtt, d.rAli), rangeOf("r_att"));
    if (d.rAtt < d.rAli) r.fail("r_att", "expected r_att >= r_ali (" + std::to_string(d.rAli) + ")");
  }
  r.resolve("r_ali", d.rAli);
  r.resolve("r_att", d.rAtt);
  {
    JsonReader nz = r.object("noise", false);
    const std::string type = nz.choice("type", "curl", {"curl", "perlin", "white", "gaussian"});
    p.noise = type == "curl"     ? BswarmNoise::kCurl
              : type == "perlin" ? BswarmNoise::kPerlin
              : type == "white"  ? BswarmNoise::kWhite
                                 : BswarmNoise::kGaussian;
    p.scale = nz.number("scale", p.scale, Range::positive());
    p.noiseUnit = nz.number("unit", p.noiseUnit, Range::length());
    checkNoiseFrequency(nz, "scale", context.world.domain, p.scale, 1.0 / p.noiseUnit);
    d.gain = nz.number("gain", d.gain, rangeOf("gain"));
    readSeeds(nz, "seeds", p.seeds);
    p.noiseCells = readCells(nz, "cells", false, 2, 1024);
    nz.finish();
  }
  for (JsonReader& s : r.objectArray("stimuli", false, 0)) {
    StimulusSpec st;
    st.kind = readKind(s);
    st.path = readPath(s, "a stimulus");
    st.radius = s.number("radius", 0.0, Range::nonNegative().limited(0.0, kMaxLength));
    st.visualRange =
        s.has("visual_range") ? s.requireNumber("visual_range", Range::nonNegative().limited(0.0, kMaxLength)) : -1.0;
    st.weight = s.number("weight", 1.0, Range::nonNegative().limited(0.0, kMaxForce));
    st.solid = s.boolean("solid", st.kind == StimulusSpec::Kind::kPredator && st.radius > 0.0);
    if (st.solid && !(st.radius > 0.0)) s.fail("solid", "only a sphere stimulus (radius > 0) can be solid");
    s.finish();
    p.stimuli.push_back(st);
  }
  if (r.has("attached_stimulus")) {
    JsonReader a = r.object("attached_stimulus", false);
    p.attached.enabled = true;
    p.attached.kind = readKind(a);
    p.attached.distance = a.number("distance", 1.0, Range::length());
    p.attached.angle = a.number("angle", 0.0, Range::closed(-180.0, 180.0));
    p.attached.axis = readAxis(a, "axis", Vec3d::UnitZ());
    p.attached.weight = a.number("weight", 1.0, Range::nonNegative().limited(0.0, kMaxForce));
    a.finish();
  }
  {
    JsonReader e = r.object("escape", false);
    p.escapeAxis = readAxis(e, "axis", p.escapeAxis);
    p.escapeAngleMin = e.number("angle_min", p.escapeAngleMin, Range::closed(-180.0, 180.0));
    p.escapeAngleMax = e.number("angle_max", p.escapeAngleMax, Range::closed(-180.0, 180.0));
    if (p.escapeAngleMax < p.escapeAngleMin) e.fail("angle_max", "expected angle_max >= angle_min");
    e.finish();
  }
  {
    JsonReader o = r.object("orca", false);
    // float in ORCA: lengths, durations and speeds within the limits stay finite and > 0 there
    p.radius = o.number("radius", p.radius, Range::length());
    p.neighborDistance = o.number("neighbor_distance",
                                  std::min(kMaxLength, std::max(p.neighborDistance, 4.0 * p.radius)), Range::length());
    p.maxNeighbors = static_cast<int>(o.integer("max_neighbors", p.maxNeighbors, 0, 256));
    p.timeHorizon = o.number("time_horizon", p.timeHorizon, Range::duration());
    p.timeHorizonObstacle = o.number("time_horizon_obstacle", p.timeHorizonObstacle, Range::duration());
    p.maxSpeed = o.number("max_speed", p.maxSpeed, Range::positiveSpeed());
    o.finish();
  }
  p.sdfCells = readCells(r, "sdf_cells", false, 2, 1024);
  p.theta = r.number("far_field_theta", p.theta, Range::closed(0.0, 2.0));
  // schedule: [{"time": t, "<param>": value, ...}, ...]; each parameter interpolates between the keys naming it
  std::vector<JsonReader> keys = r.objectArray("schedule", false, 0);
  double lastTime = -1.0;
  for (JsonReader& k : keys) {
    const double t = k.requireNumber("time", Range::nonNegative());
    if (!(t > lastTime)) k.failExpected("time", "a time later than the previous key's", t);
    lastTime = t;
    bool any = false;
    for (const auto& field : dynamicFields()) {
      if (!k.has(field.name)) continue;
      any = true;
      const double v = k.requireNumber(field.name, field.range);
      auto it = std::find_if(p.schedule.tracks.begin(), p.schedule.tracks.end(),
                             [&](const BswarmSchedule::Track& tr) { return tr.name == field.name; });
      if (it == p.schedule.tracks.end()) {
        p.schedule.tracks.push_back({field.name, {}, {}});
        it = p.schedule.tracks.end() - 1;
      }
      it->times.push_back(t);
      it->values.push_back(v);
    }
    if (!any) k.fail("time", "a schedule key must set at least one parameter (gamma, gain, lambda_*, r_*)");
    k.finish();
  }
  return p;
}

std::shared_ptr<const ModelConfig> parseBswarm(JsonReader& params, const ModelContext& context) {
  return std::make_shared<BswarmConfig>(readBswarmParams(params, context));
}

std::unique_ptr<Model> makeBswarm(const BswarmParams& params, const World& world) {
  return std::make_unique<BswarmModel>(params, world);
}

}  // namespace swarmsim
