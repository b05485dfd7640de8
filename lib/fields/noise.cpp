#include "fields/noise.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace swarmsim {

namespace {

// splitmix64 (Steele, Lea & Flood 2014): a 64-bit counter passed through a bijective mixer
std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// the 12 cube-edge directions, padded to 16 with four of them (a regular tetrahedron,
// as in Perlin 2002) so a hash picks one with `& 15`
constexpr double kGrad[16][3] = {
    {1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {1, 0, 1}, {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
    {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1}, {1, 1, 0}, {-1, 1, 0}, {0, -1, 1}, {0, -1, -1},
};

// 1 / (largest reachable magnitude, 1.036354, rounded up): see noise.hpp
constexpr double kNormalize = 1.0 / 1.0364;

inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
inline double lerp(double a, double b, double t) { return a + t * (b - a); }
inline double dotGrad(int hash, double x, double y, double z) {
  const double* g = kGrad[hash & 15];
  return g[0] * x + g[1] * y + g[2] * z;
}

}  // namespace

PerlinNoise3::PerlinNoise3(std::uint64_t seed) {
  // Fisher–Yates shuffle of 0..255 (modulo bias of a 64-bit draw is below 2^-55)
  std::array<std::uint8_t, 256> p{};
  for (int i = 0; i < 256; ++i) p[i] = static_cast<std::uint8_t>(i);
  std::uint64_t state = seed;
  for (int i = 255; i > 0; --i) {
    const auto j = static_cast<int>(splitmix64(state) % static_cast<std::uint64_t>(i + 1));
    std::swap(p[i], p[j]);
  }
  for (int i = 0; i < 512; ++i) perm_[i] = p[i & 255];
}

double PerlinNoise3::operator()(const Vec3d& p) const {
  // lattice cell (wrapped to the table's period) and offset inside it
  const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const int X = static_cast<int>(static_cast<long long>(fx) & 255);
  const int Y = static_cast<int>(static_cast<long long>(fy) & 255);
  const int Z = static_cast<int>(static_cast<long long>(fz) & 255);
  const double x = p.x() - fx, y = p.y() - fy, z = p.z() - fz;
  const double u = fade(x), v = fade(y), w = fade(z);

  // hashes of the 8 corners
  const int a = perm_[X] + Y, aa = perm_[a] + Z, ab = perm_[a + 1] + Z;
  const int b = perm_[X + 1] + Y, ba = perm_[b] + Z, bb = perm_[b + 1] + Z;

  // blend the corner contributions g · (t − c), x first, then y, then z
  const double x00 = lerp(dotGrad(perm_[aa], x, y, z), dotGrad(perm_[ba], x - 1, y, z), u);
  const double x10 = lerp(dotGrad(perm_[ab], x, y - 1, z), dotGrad(perm_[bb], x - 1, y - 1, z), u);
  const double x01 = lerp(dotGrad(perm_[aa + 1], x, y, z - 1), dotGrad(perm_[ba + 1], x - 1, y, z - 1), u);
  const double x11 = lerp(dotGrad(perm_[ab + 1], x, y - 1, z - 1), dotGrad(perm_[bb + 1], x - 1, y - 1, z - 1), u);
  const double value = lerp(lerp(x00, x10, v), lerp(x01, x11, v), w) * kNormalize;
  return std::clamp(value, -1.0, 1.0);  // a no-op but for rounding
}

double PerlinNoise3::withGradient(const Vec3d& p, Vec3d& grad) const {
  const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const int X = static_cast<int>(static_cast<long long>(fx) & 255);
  const int Y = static_cast<int>(static_cast<long long>(fy) & 255);
  const int Z = static_cast<int>(static_cast<long long>(fz) & 255);
  const double x = p.x() - fx, y = p.y() - fy, z = p.z() - fz;
  const double u = fade(x), v = fade(y), w = fade(z);
  const auto dfade = [](double t) { return 30.0 * t * t * (t - 1.0) * (t - 1.0); };
  const double du = dfade(x), dv = dfade(y), dw = dfade(z);

  const int a = perm_[X] + Y, aa = perm_[a] + Z, ab = perm_[a + 1] + Z;
  const int b = perm_[X + 1] + Y, ba = perm_[b] + Z, bb = perm_[b + 1] + Z;
  // corner gradients G and values g = G · (t − c), corners named by (c_x, c_y, c_z)
  const double* G000 = kGrad[perm_[aa] & 15];
  const double* G100 = kGrad[perm_[ba] & 15];
  const double* G010 = kGrad[perm_[ab] & 15];
  const double* G110 = kGrad[perm_[bb] & 15];
  const double* G001 = kGrad[perm_[aa + 1] & 15];
  const double* G101 = kGrad[perm_[ba + 1] & 15];
  const double* G011 = kGrad[perm_[ab + 1] & 15];
  const double* G111 = kGrad[perm_[bb + 1] & 15];
  const auto dot = [](const double* g, double tx, double ty, double tz) { return g[0] * tx + g[1] * ty + g[2] * tz; };
  const double g000 = dot(G000, x, y, z), g100 = dot(G100, x - 1, y, z);
  const double g010 = dot(G010, x, y - 1, z), g110 = dot(G110, x - 1, y - 1, z);
  const double g001 = dot(G001, x, y, z - 1), g101 = dot(G101, x - 1, y, z - 1);
  const double g011 = dot(G011, x, y - 1, z - 1), g111 = dot(G111, x - 1, y - 1, z - 1);

  // the same blend as operator() (so the values agree bit for bit)
  const double x00 = lerp(g000, g100, u), x10 = lerp(g010, g110, u);
  const double x01 = lerp(g001, g101, u), x11 = lerp(g011, g111, u);
  const double y0 = lerp(x00, x10, v), y1 = lerp(x01, x11, v);
  const double value = lerp(y0, y1, w) * kNormalize;

  // d/dt of the blend: the weights' derivatives times the corner values, plus
  // the weights times the corner gradients
  const double dx00 = g100 - g000, dx10 = g110 - g010, dx01 = g101 - g001, dx11 = g111 - g011;
  const double dy0 = x10 - x00, dy1 = x11 - x01;
  const double dValue[3] = {
      du * lerp(lerp(dx00, dx10, v), lerp(dx01, dx11, v), w),
      dv * lerp(dy0, dy1, w),
      dw * (y1 - y0),
  };
  for (int c = 0; c < 3; ++c) {
    const double l00 = lerp(G000[c], G100[c], u), l10 = lerp(G010[c], G110[c], u);
    const double l01 = lerp(G001[c], G101[c], u), l11 = lerp(G011[c], G111[c], u);
    grad[c] = (dValue[c] + lerp(lerp(l00, l10, v), lerp(l01, l11, v), w)) * kNormalize;
  }
  return std::clamp(value, -1.0, 1.0);
}

}  // namespace swarmsim
