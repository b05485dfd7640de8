#include "eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/parallel.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim::eval {

const char* metricName(int m) {
  static const char* const names[kMetricCount] = {"v", "a", "omega", "alpha", "jerk", "d", "eta",
                                                  "pol", "mill", "r_c", "d_rel"};
  return names[m];
}

const char* metricUnit(int m) {
  static const char* const units[kMetricCount] = {"m/s", "m/s^2", "rad/s", "rad/s^2", "m/s^3", "m", "1/s",
                                                  "1",   "1",     "m",     "1"};
  return units[m];
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Slot {
  bool loaded = false;
  Frame frame;
  std::vector<double> v;      // 3 per individual (NaN: not available)
  std::vector<double> omega;  // per individual (NaN: not available)
};

double norm3(const double* a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

// nearest other individual of every row of f: index (or -1) and distance
void nearestNeighbours(const Frame& f, std::vector<std::ptrdiff_t>& nn, std::vector<double>& dist) {
  const std::size_t n = f.size();
  nn.assign(n, -1);
  dist.assign(n, kNaN);
  if (n < 2) return;
  const double* p = f.pos.data();
  const auto d2of = [p](std::size_t i, std::size_t j) {
    const double dx = p[3 * j] - p[3 * i], dy = p[3 * j + 1] - p[3 * i + 1], dz = p[3 * j + 2] - p[3 * i + 2];
    return dx * dx + dy * dy + dz * dz;
  };
  if (n <= 64) {  // brute force; ties -> the lower row (= lower id)
    for (std::size_t i = 0; i < n; ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        const double d2 = d2of(i, j);
        if (d2 < best) {
          best = d2;
          nn[i] = static_cast<std::ptrdiff_t>(j);
        }
      }
      dist[i] = std::sqrt(best);
    }
    return;
  }
  std::vector<float> x(n), y(n), z(n);
  double lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0], p[1], p[2]};
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = static_cast<float>(p[3 * i]);
    y[i] = static_cast<float>(p[3 * i + 1]);
    z[i] = static_cast<float>(p[3 * i + 2]);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[3 * i + static_cast<std::size_t>(a)]);
      hi[a] = std::max(hi[a], p[3 * i + static_cast<std::size_t>(a)]);
    }
  }
  const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-9});
  const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  // a radius above the typical spacing in 1, 2 or 3 dimensions
  const double r0 = ext / std::cbrt(static_cast<double>(n));
  UniformGrid grid;
  grid.build(x.data(), y.data(), z.data(), n, static_cast<float>(r0));
  const auto& order = grid.order();
  parallelFor(n, [&](std::size_t i) {
    double r = r0;
    while (true) {
      double best = std::numeric_limits<double>::infinity();
      std::ptrdiff_t bestJ = -1;
      // float candidates within a slightly larger radius, exact distances in double
      grid.forEachNeighbor(x[i], y[i], z[i], static_cast<float>(r * 1.001) + 1e-30f,
                           [&](std::uint32_t k, float, float, float, float) {
                             const std::size_t j = order[k];
                             if (j == i) return;
                             const double d2 = d2of(i, j);
                             if (d2 < best || (d2 == best && static_cast<std::ptrdiff_t>(j) < bestJ)) {
                               best = d2;
                               bestJ = static_cast<std::ptrdiff_t>(j);
                             }
                           });
      // the nearest within r is the nearest overall; past the diagonal everything was seen
      if ((bestJ >= 0 && best <= r * r) || r > 2.0 * diag + 1e-9) {
        nn[i] = bestJ;
        dist[i] = std::sqrt(best);
        return;
      }
      r *= 2.0;
    }
  });
}

}  // namespace


void centroidAndSpacing(const Frame& f, double c[3], double& spacing) {
  const std::size_t n = f.size();
  const double* p = f.pos.data();
  c[0] = c[1] = c[2] = 0;
  spacing = 0;
  if (n == 0) return;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t d = 0; d < 3; ++d) c[d] += p[3 * i + d];
  }
  for (std::size_t d = 0; d < 3; ++d) c[d] /= static_cast<double>(n);
  double rg2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t d = 0; d < 3; ++d) rg2 += (p[3 * i + d] - c[d]) * (p[3 * i + d] - c[d]);
  }
  spacing = std::sqrt(rg2 / static_cast<double>(n)) / std::cbrt(static_cast<double>(n));
}

namespace {  // the collective metrics

// pol, mill (one value each, appended to out) and r_c, d_rel (per row into perRow) of frame f
void collective(const Frame& f, const std::vector<double>& v, const std::vector<double>& nnDist,
                std::array<std::vector<double>, kMetricCount>& perRow, FrameValues& out) {
  const std::size_t n = f.size();
  if (n < 2) return;
  const double* p = f.pos.data();
  double c[3], spacing = 0;
  centroidAndSpacing(f, c, spacing);
  double dir[3] = {0, 0, 0}, l[3] = {0, 0, 0}, lnorm = 0;
  std::size_t moving = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r[3] = {p[3 * i] - c[0], p[3 * i + 1] - c[1], p[3 * i + 2] - c[2]};
    const double rn = norm3(r);
    perRow[kCentreDistance][i] = rn;
    const double* vi = &v[3 * i];
    if (std::isnan(vi[0])) continue;
    const double s = norm3(vi);
    if (s == 0.0) continue;
    ++moving;
    for (std::size_t d = 0; d < 3; ++d) dir[d] += vi[d] / s;
    l[0] += r[1] * vi[2] - r[2] * vi[1];
    l[1] += r[2] * vi[0] - r[0] * vi[2];
    l[2] += r[0] * vi[1] - r[1] * vi[0];
    lnorm += rn * s;
  }
  if (n >= 3) {
    if (spacing > 0.0) {
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isnan(nnDist[i])) perRow[kRelNnDistance][i] = nnDist[i] / spacing;
      }
    }
  }
  if (moving >= 3) {
    out[kPolarisation].push_back(norm3(dir) / static_cast<double>(moving));
    if (lnorm > 0.0) out[kMilling].push_back(norm3(l) / lnorm);
  }
}

}  // namespace

void computeMetrics(TrackSource& source, double scale,
                    const std::function<void(const FrameValues&, const SampleView&)>& sink) {
  const TrackInfo& info = source.info();
  const double dt = info.dt;
  const bool derived = !info.hasVelocity;
  std::array<Slot, 8> ring;
  const auto slot = [&](std::int64_t j) -> Slot* {
    if (j < info.first || j >= info.last) return nullptr;
    Slot& s = ring[static_cast<std::size_t>(j & 7)];
    return s.loaded && s.frame.sample == j ? &s : nullptr;
  };
  std::array<std::vector<double>, kMetricCount> perRow;
  std::vector<std::ptrdiff_t> nn;
  std::vector<double> nnDist;
  FrameValues out;

  for (std::int64_t k = info.first; k < info.last + 3; ++k) {
    if (k < info.last) {  // load sample k
      Slot& s = ring[static_cast<std::size_t>(k & 7)];
      source.read(k, s.frame);
      s.loaded = true;
      const std::size_t n = s.frame.size();
      if (scale != 1.0) {
        for (auto& c : s.frame.pos) c *= scale;
        for (auto& c : s.frame.vel) c *= scale;
      }
      if (derived) {
        s.v.assign(3 * n, kNaN);
      } else {
        s.v = s.frame.vel;
      }
      s.omega.assign(n, kNaN);
    }
    // stage A: derived velocities of sample k-1
    if (Slot* c = derived ? slot(k - 1) : nullptr) {
      const Slot *pv = slot(k - 2), *nx = slot(k);
      if (pv && nx) {
        const Frame& f = c->frame;
        parallelFor(f.size(), [&](std::size_t i) {
          const std::ptrdiff_t a = pv->frame.find(f.id[i]), b = nx->frame.find(f.id[i]);
          if (a < 0 || b < 0) return;
          for (std::size_t d = 0; d < 3; ++d) {
            c->v[3 * i + d] = (nx->frame.pos[3 * static_cast<std::size_t>(b) + d] -
                               pv->frame.pos[3 * static_cast<std::size_t>(a) + d]) /
                              (2.0 * dt);
          }
        });
      }
    }
    // stage B: angular velocity of sample k-2
    if (Slot* c = slot(k - 2)) {
      const Slot *pv = slot(k - 3), *nx = slot(k - 1);
      if (pv && nx) {
        const Frame& f = c->frame;
        parallelFor(f.size(), [&](std::size_t i) {
          const std::ptrdiff_t a = pv->frame.find(f.id[i]), b = nx->frame.find(f.id[i]);
          if (a < 0 || b < 0) return;
          const double* u = &pv->v[3 * static_cast<std::size_t>(a)];
          const double* w = &nx->v[3 * static_cast<std::size_t>(b)];
          if (std::isnan(u[0]) || std::isnan(w[0])) return;
          if (norm3(u) == 0.0 || norm3(w) == 0.0) return;
          const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
          const double dot = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
          c->omega[i] = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot) / (2.0 * dt);
        });
      }
    }
    // stage C: every metric of sample k-3
    if (Slot* c = slot(k - 3)) {
      const Slot *pv = slot(k - 4), *nx = slot(k - 2);
      const Frame& f = c->frame;
      const std::size_t n = f.size();
      for (auto& r : perRow) r.assign(n, kNaN);
      nearestNeighbours(f, nn, nnDist);
      parallelFor(n, [&](std::size_t i) {
        const double* vi = &c->v[3 * i];
        const bool hasVi = !std::isnan(vi[0]);
        if (hasVi) perRow[kSpeed][i] = norm3(vi);
        perRow[kOmega][i] = c->omega[i];
        const std::ptrdiff_t a = pv ? pv->frame.find(f.id[i]) : -1, b = nx ? nx->frame.find(f.id[i]) : -1;
        if (a >= 0 && b >= 0) {
          const double* u = &pv->v[3 * static_cast<std::size_t>(a)];
          const double* w = &nx->v[3 * static_cast<std::size_t>(b)];
          if (!std::isnan(u[0]) && !std::isnan(w[0])) {
            const double dv[3] = {w[0] - u[0], w[1] - u[1], w[2] - u[2]};
            perRow[kAccel][i] = norm3(dv) / (2.0 * dt);
            if (hasVi) {
              const double j3[3] = {w[0] - 2.0 * vi[0] + u[0], w[1] - 2.0 * vi[1] + u[1], w[2] - 2.0 * vi[2] + u[2]};
              perRow[kJerk][i] = norm3(j3) / (dt * dt);
            }
          }
          const double oa = pv->omega[static_cast<std::size_t>(a)], ob = nx->omega[static_cast<std::size_t>(b)];
          if (!std::isnan(oa) && !std::isnan(ob)) perRow[kAlpha][i] = std::abs(ob - oa) / (2.0 * dt);
        }
        if (nn[i] >= 0) {
          const double d = nnDist[i];
          perRow[kNnDistance][i] = d;
          const double* vj = &c->v[3 * static_cast<std::size_t>(nn[i])];
          if (d > 0.0 && hasVi && !std::isnan(vj[0])) {
            const double dv[3] = {vj[0] - vi[0], vj[1] - vi[1], vj[2] - vi[2]};
            perRow[kEta][i] = norm3(dv) / d;
          }
        }
      });
      for (auto& o : out) o.clear();
      collective(f, c->v, nnDist, perRow, out);
      for (int m = 0; m < kMetricCount; ++m) {
        if (m == kPolarisation || m == kMilling) continue;
        auto& o = out[static_cast<std::size_t>(m)];
        for (double x : perRow[static_cast<std::size_t>(m)]) {
          if (!std::isnan(x)) o.push_back(x);
        }
      }
      sink(out, SampleView{f.sample, &f, &c->v});
    }
  }
}

}  // namespace swarmsim::eval
