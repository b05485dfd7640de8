#include "models/replay/replay.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>

#include "core/error.hpp"
#include "eval/tracks.hpp"

namespace swarmsim {

bool ReplayTracks::at(std::size_t i, double u, double p[3], double v[3]) const {
  const Track& t = tracks[i];
  double k = std::floor(u);
  double f = u - k;
  if (f > 1.0 - 1e-6) {  // on a sample, up to the rounding of start + step * dt
    k += 1.0;
    f = 0.0;
  } else if (f < 1e-6) {
    f = 0.0;
  }
  const double rel = k - static_cast<double>(t.first);
  if (!(rel >= 0.0) || rel >= static_cast<double>(t.samples())) return false;
  const auto a = static_cast<std::size_t>(rel);
  if (!t.present[a]) return false;
  if (f == 0.0) {
    std::copy_n(&t.pos[3 * a], 3, p);
    std::copy_n(&t.vel[3 * a], 3, v);
    return true;
  }
  if (a + 1 >= t.present.size() || !t.present[a + 1]) return false;  // the track ends, or a gap
  for (int c = 0; c < 3; ++c) {
    const double p0 = t.pos[3 * a + c], p1 = t.pos[3 * (a + 1) + c];
    p[c] = p0 + f * (p1 - p0);
    v[c] = recordedVelocity ? t.vel[3 * a + c] + f * (t.vel[3 * (a + 1) + c] - t.vel[3 * a + c]) : (p1 - p0) / dt;
  }
  return true;
}

ReplayTracks readReplayTracks(const std::string& file, const std::string& swarm, const std::string& delimiter,
                              const std::string& columns) {
  eval::SourceOptions opt;
  opt.swarm = swarm;
  opt.csv.delimiter = delimiter;
  opt.csv.columns = columns;
  std::unique_ptr<eval::TrackSource> src = eval::openTracks(file, opt);
  const eval::TrackInfo& info = src->info();
  ReplayTracks out;
  out.dt = info.dt;
  out.recordedVelocity = info.hasVelocity;
  // first pass: each individual's first and last sample; ids in ascending order are the agents
  std::map<std::int64_t, std::pair<std::int64_t, std::int64_t>> span;
  eval::Frame f;
  for (std::int64_t k = info.first; k < info.last; ++k) {
    src->read(k, f);
    for (std::size_t i = 0; i < f.size(); ++i) {
      bool finite = true;
      for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(f.pos[3 * i + c]);
      if (!finite) continue;
      auto [it, fresh] = span.try_emplace(f.id[i], k, k);
      if (!fresh) it->second.second = k;
    }
  }
  if (span.empty()) throw InputError(file + ": no individual has a position to replay");
  std::map<std::int64_t, std::size_t> slot;
  for (const auto& [id, s] : span) {
    slot[id] = out.tracks.size();
    ReplayTracks::Track t;
    t.first = s.first - info.first;
    const auto n = static_cast<std::size_t>(s.second - s.first + 1);
    t.pos.assign(3 * n, 0.0);
    t.vel.assign(3 * n, 0.0);
    t.present.assign(n, 0);
    out.tracks.push_back(std::move(t));
  }
  // second pass: the samples
  for (std::int64_t k = info.first; k < info.last; ++k) {
    src->read(k, f);
    for (std::size_t i = 0; i < f.size(); ++i) {
      bool finite = true;
      for (int c = 0; c < 3; ++c) {
        finite = finite && std::isfinite(f.pos[3 * i + c]) && std::fabs(f.pos[3 * i + c]) <= kMaxCoordinate;
      }
      if (!finite) {
        if (std::isfinite(f.pos[3 * i]) && std::isfinite(f.pos[3 * i + 1]) && std::isfinite(f.pos[3 * i + 2])) {
          throw InputError(file + ": a position beyond the coordinate limit (" + std::to_string(kMaxCoordinate) +
                           " m) at sample " + std::to_string(k - info.first));
        }
        continue;
      }
      ReplayTracks::Track& t = out.tracks[slot.at(f.id[i])];
      const auto a = static_cast<std::size_t>(k - info.first - t.first);
      t.present[a] = 1;
      for (int c = 0; c < 3; ++c) {
        t.pos[3 * a + c] = f.pos[3 * i + c];
        if (info.hasVelocity) t.vel[3 * a + c] = std::isfinite(f.vel[3 * i + c]) ? f.vel[3 * i + c] : 0.0;
      }
    }
  }
  if (!info.hasVelocity) {  // forward differences; a track's last sample (or one before a gap) the backward one
    for (ReplayTracks::Track& t : out.tracks) {
      const std::size_t n = t.present.size();
      for (std::size_t a = 0; a < n; ++a) {
        if (!t.present[a]) continue;
        std::size_t b = a + 1, e = a;
        if (b >= n || !t.present[b]) {
          if (a == 0 || !t.present[a - 1]) continue;  // a lone sample: at rest
          b = a;
          e = a - 1;
        }
        for (int c = 0; c < 3; ++c) t.vel[3 * a + c] = (t.pos[3 * b + c] - t.pos[3 * e + c]) / out.dt;
      }
    }
  }
  return out;
}

namespace {

class Replay final : public Model {
 public:
  explicit Replay(const ReplayParams& p) : p_(p) {}

  void place(const World&, SwarmState& s, double time) override { placeAt(s, time); }
  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    placeAt(s, info.time + world.dt);  // the state at the end of the step
  }
  std::vector<std::string> statNames() const override { return {"present"}; }
  void takeFrameStats(std::vector<double>& values) override { values.assign(1, present_); }
  Json facts() const override {
    const ReplayTracks& t = *p_.tracks;
    std::int64_t last = 0;
    for (const auto& x : t.tracks) last = std::max(last, x.first + x.samples());
    return {{"file", p_.file},
            {"individuals", t.tracks.size()},
            {"sample_interval", t.dt},
            {"start", p_.start},
            {"translate", {p_.translate.x(), p_.translate.y(), p_.translate.z()}},
            {"recorded_seconds", static_cast<double>(std::max<std::int64_t>(0, last - 1)) * t.dt},
            {"velocity", t.recordedVelocity ? "recorded" : "differenced"}};
  }

 private:
  void placeAt(SwarmState& s, double time) {
    const ReplayTracks& t = *p_.tracks;
    const double u = (p_.start + time) / t.dt;
    constexpr float kAbsent = std::numeric_limits<float>::quiet_NaN();
    std::size_t present = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {  // slot i is agent i, whose id is i
      double p[3], v[3];
      if (t.at(s.id[i], u, p, v)) {
        s.setPosition(i, (Vec3d(p[0], p[1], p[2]) + p_.translate).cast<float>());
        s.setVelocity(i, Vec3d(v[0], v[1], v[2]).cast<float>());
        ++present;
      } else {
        s.setPosition(i, Vec3(kAbsent, kAbsent, kAbsent));
        s.setVelocity(i, Vec3(kAbsent, kAbsent, kAbsent));
      }
    }
    present_ = static_cast<double>(present);
  }

  ReplayParams p_;
  double present_ = 0.0;  // agents present after the last placement (the frame statistic "present")
};

class ReplayConfig final : public ModelConfig {
 public:
  explicit ReplayConfig(ReplayParams p) : p_(std::move(p)) {}
  std::unique_ptr<Model> build(const World&) const override { return std::make_unique<Replay>(p_); }
  std::int64_t placedAgents() const override { return static_cast<std::int64_t>(p_.tracks->tracks.size()); }

 private:
  ReplayParams p_;
};

}  // namespace

std::shared_ptr<const ModelConfig> parseReplay(JsonReader& r, const ModelContext& /*context*/) {
  ReplayParams p;
  p.file = r.requireInputPath("file");
  p.swarm = r.string("swarm", "");
  p.delimiter = r.string("delimiter", "");
  p.columns = r.string("columns", "");
  p.start = r.number("start", 0.0, Range::nonNegative().limited(0.0, kMaxDuration));
  p.translate = r.vec3("translate", Vec3d::Zero(), Range::coordinate());
  try {
    p.tracks = std::make_shared<const ReplayTracks>(readReplayTracks(p.file, p.swarm, p.delimiter, p.columns));
  } catch (const InputError& e) {
    r.fail("file", e.what());
  }
  return std::make_shared<ReplayConfig>(std::move(p));
}

}  // namespace swarmsim
