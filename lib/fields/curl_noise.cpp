#include "fields/curl_noise.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/parallel.hpp"

namespace swarmsim {

namespace {

bool positiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

std::array<PerlinNoise3, 3> makePerlin(const NoiseParams& p) {
  return {PerlinNoise3(p.seeds[0]), PerlinNoise3(p.seeds[1]), PerlinNoise3(p.seeds[2])};
}

// the cell (i, j, k) of a flat x-fastest index
std::array<int, 3> cellOfIndex(const GridSpec& s, std::size_t idx) {
  const auto nx = static_cast<std::size_t>(s.n[0]), ny = static_cast<std::size_t>(s.n[1]);
  return {static_cast<int>(idx % nx), static_cast<int>((idx / nx) % ny), static_cast<int>(idx / (nx * ny))};
}

// ∂v/∂x_a at flat index idx, where q is the cell's coordinate along a, n the cell count,
// s the index stride and h the spacing along a
Vec3d partial(const std::vector<Vec3>& v, std::size_t idx, int q, int n, std::size_t s, double h) {
  auto at = [&](std::size_t m) -> Vec3d { return v[m].cast<double>(); };
  if (n == 1) return Vec3d::Zero();
  if (q == 0) {
    if (n == 2) return (at(idx + s) - at(idx)) / h;
    return (-3.0 * at(idx) + 4.0 * at(idx + s) - at(idx + 2 * s)) / (2.0 * h);
  }
  if (q == n - 1) {
    if (n == 2) return (at(idx) - at(idx - s)) / h;
    return (3.0 * at(idx) - 4.0 * at(idx - s) + at(idx - 2 * s)) / (2.0 * h);
  }
  return (at(idx + s) - at(idx - s)) / (2.0 * h);
}

// the three partial derivatives ∂v/∂x, ∂v/∂y, ∂v/∂z at cell c
std::array<Vec3d, 3> jacobianColumns(const Grid3<Vec3>& v, const std::array<int, 3>& c) {
  const GridSpec& s = v.spec;
  const std::size_t idx = s.index(c[0], c[1], c[2]);
  const std::size_t stride[3] = {1, static_cast<std::size_t>(s.n[0]),
                                 static_cast<std::size_t>(s.n[0]) * static_cast<std::size_t>(s.n[1])};
  std::array<Vec3d, 3> d;
  for (int a = 0; a < 3; ++a) d[a] = partial(v.data, idx, c[a], s.n[a], stride[a], s.cell[a]);
  return d;
}

}  // namespace

double ramp(double r) {
  if (!(r > 0.0)) return 0.0;
  if (r >= 1.0) return 1.0;
  const double r2 = r * r;
  return r * (15.0 / 8.0 - r2 * (10.0 / 8.0 - r2 * (3.0 / 8.0)));
}

NoisePotential::NoisePotential(const NoiseParams& params)
    : params_(params), perlin_(makePerlin(params)), frequency_(0.0), potentialFactor_(0.0) {
  if (!positiveFinite(params.scale) || !positiveFinite(params.unit) || !positiveFinite(params.d0))
    throw std::invalid_argument("noise parameters: scale, unit and d0 must be positive (got scale " +
                                std::to_string(params.scale) + ", unit " + std::to_string(params.unit) + ", d0 " +
                                std::to_string(params.d0) + ")");
  frequency_ = params.scale / params.unit;
  potentialFactor_ = params.gain * params.unit / params.scale;
}

Vec3d NoisePotential::noise(const Vec3d& x) const {
  const Vec3d u = x * frequency_;
  return {perlin_[0](u), perlin_[1](u), perlin_[2](u)};
}

Vec3d NoisePotential::curlRaw(const Vec3d& x) const {
  const Vec3d u = x * frequency_;
  Vec3d g[3];  // g[c] = ∇ P_c in lattice units
  for (int c = 0; c < 3; ++c) perlin_[c].withGradient(u, g[c]);
  // ∂P_c/∂x_a = potentialFactor · frequency · ∂P_c/∂u_a = gain · ∂P_c/∂u_a
  return Vec3d(g[2].y() - g[1].z(), g[0].z() - g[2].x(), g[1].x() - g[0].y()) * params_.gain;
}

void NoisePotential::curlRawBatch(const double* x, const double* y, const double* z, std::size_t n, double* cx,
                                  double* cy, double* cz, bool avx, bool wideLanes, bool vbmi) const {
  // eight points at a time on AVX-512, else four (the same bits)
  const bool wide = avx && wideLanes;
  const std::size_t L = wide ? PerlinNoise3::kWideLanes : PerlinNoise3::kLanes;
  // a chunk's lattice coordinates are all written before the lanes load them (a vector load of values just
  // stored one by one would wait for the stores); the last batch of lanes is padded with the chunk's first point
  constexpr std::size_t kChunk = 64;
  static_assert(kChunk % PerlinNoise3::kLanes == 0 && kChunk % PerlinNoise3::kWideLanes == 0, "whole batches");
  double u[3][kChunk];
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t m = std::min(kChunk, n - start);
    for (std::size_t i = 0; i < m; ++i) {
      u[0][i] = x[start + i] * frequency_;
      u[1][i] = y[start + i] * frequency_;
      u[2][i] = z[start + i] * frequency_;
    }
    for (std::size_t i = m; i % L != 0; ++i) {
      for (auto& ua : u) ua[i] = ua[0];
    }
    for (std::size_t i = 0; i < m; i += L) {
      // g[a][c * L + l] = ∂P_c/∂u_a at point i + l, curlRaw's g[c][a]
      double g[3][3 * PerlinNoise3::kWideLanes];
      if (wide) {
        PerlinNoise3::withGradientWide(perlin_.data(), 3, u[0] + i, u[1] + i, u[2] + i, g[0], g[1], g[2], vbmi);
      } else {
        PerlinNoise3::withGradientLanes(perlin_.data(), 3, u[0] + i, u[1] + i, u[2] + i, nullptr, g[0], g[1], g[2],
                                        avx);
      }
      for (std::size_t l = 0; l < L && i + l < m; ++l) {
        const std::size_t k = start + i + l;
        cx[k] = (g[1][2 * L + l] - g[2][L + l]) * params_.gain;
        cy[k] = (g[2][l] - g[0][2 * L + l]) * params_.gain;
        cz[k] = (g[0][L + l] - g[1][l]) * params_.gain;
      }
    }
  }
}

Vec3d NoisePotential::operator()(const Vec3d& x, const Grid3<float>* sdf) const {
  const Vec3d P = raw(x);
  if (!sdf) return P;
  // α from the signed distance; nothing to blend far from obstacles
  const Vec3 xf = x.cast<float>();
  const double alpha = ramp(static_cast<double>(sdf->sample(xf)) / params_.d0);
  if (alpha >= 1.0) return P;
  // n: normalised central-difference gradient of the interpolated distance, one sdf cell apart
  Vec3d grad;
  for (int a = 0; a < 3; ++a) {
    Vec3 e = Vec3::Zero();
    e[a] = static_cast<float>(sdf->spec.cell[a]);
    grad[a] = (static_cast<double>(sdf->sample(xf + e)) - static_cast<double>(sdf->sample(xf - e))) /
              (2.0 * sdf->spec.cell[a]);
  }
  const double g2 = grad.squaredNorm();
  const Vec3d n = g2 > 1e-30 ? Vec3d(grad / std::sqrt(g2)) : Vec3d::Zero();
  return alpha * P + (1.0 - alpha) * n.dot(P) * n;
}

Grid3<Vec3> noisePotential(const GridSpec& spec, const NoiseParams& params, const Grid3<float>* sdf) {
  const NoisePotential N(params);
  Grid3<Vec3> out(spec, Vec3::Zero());
  parallelFor(spec.size(), [&](std::size_t idx) {
    const auto c = cellOfIndex(spec, idx);
    out.data[idx] = N(spec.center(c[0], c[1], c[2]), sdf).cast<float>();
  });
  return out;
}

Grid3<Vec3> curl(const Grid3<Vec3>& potential) {
  const GridSpec& spec = potential.spec;
  Grid3<Vec3> out(spec, Vec3::Zero());
  parallelFor(spec.size(), [&](std::size_t idx) {
    // d[a] = ∂N/∂x_a; curl = (∂y Nz − ∂z Ny, ∂z Nx − ∂x Nz, ∂x Ny − ∂y Nx)
    const auto d = jacobianColumns(potential, cellOfIndex(spec, idx));
    out.data[idx] = Vec3d(d[1].z() - d[2].y(), d[2].x() - d[0].z(), d[0].y() - d[1].x()).cast<float>();
  });
  return out;
}

Grid3<Vec3> perlinVelocity(const GridSpec& spec, const NoiseParams& params) {
  const NoisePotential N(params);
  Grid3<Vec3> out(spec, Vec3::Zero());
  parallelFor(spec.size(), [&](std::size_t idx) {
    const auto c = cellOfIndex(spec, idx);
    out.data[idx] = (N.noise(spec.center(c[0], c[1], c[2])) * params.gain).cast<float>();
  });
  return out;
}

float divergence(const Grid3<Vec3>& v, int i, int j, int k) {
  const auto d = jacobianColumns(v, {i, j, k});
  return static_cast<float>(d[0].x() + d[1].y() + d[2].z());
}

}  // namespace swarmsim
