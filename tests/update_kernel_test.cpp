// The shape model's per-insect update on SIMD lanes (lib/models/shape/update_kernel.hpp) against the same
// equations written one insect at a time with Eigen's vectors (eq. 1, shape.hpp's distanceForce for eq. 6-7,
// Newton's second law, the top speed): the same bits on every lane set, for any block length and offset.
#include "models/shape/update_kernel.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "core/vec.hpp"
#include "lane_sets.hpp"
#include "models/shape/shape.hpp"

using namespace swarmsim;

namespace {

struct Case {
  std::size_t n = 0;
  std::vector<float> x, y, z, vx, vy, vz, cnx, cny, cnz, sx, sy, sz, fi[3], fc[3];
};

Case makeCase(std::mt19937& rng, std::size_t n) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Case c;
  c.n = n;
  for (auto* a : {&c.x, &c.y, &c.z, &c.vx, &c.vy, &c.vz, &c.cnx, &c.cny, &c.cnz, &c.sx, &c.sy, &c.sz, &c.fi[0],
                  &c.fi[1], &c.fi[2], &c.fc[0], &c.fc[1], &c.fc[2]}) {
    a->resize(n);
    for (float& v : *a) v = u(rng);
  }
  for (std::size_t k = 0; k < n; ++k) {
    switch (k % 7) {
      case 0:  // at its sample point: no F_dis
        c.sx[k] = c.x[k];
        c.sy[k] = c.y[k];
        c.sz[k] = c.z[k];
        break;
      case 1:  // beyond the influence range: the profile is 0
        c.sx[k] = c.x[k] + 5.0f;
        break;
      case 2:  // negative zeros everywhere they can reach the sums
        c.fi[0][k] = c.fc[1][k] = c.cnx[k] = c.vx[k] = -0.0f;
        break;
      case 3:  // far faster than the top speed
        c.fi[1][k] *= 400.0f;
        break;
      case 4:  // standing still, no forces
        c.vx[k] = c.vy[k] = c.vz[k] = 0.0f;
        c.fi[0][k] = c.fi[1][k] = c.fi[2][k] = c.fc[0][k] = c.fc[1][k] = c.fc[2][k] = 0.0f;
        c.cnx[k] = c.cny[k] = c.cnz[k] = 0.0f;
        break;
      default:
        break;
    }
  }
  return c;
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST_CASE("shape update: the SIMD lanes give the one-insect-at-a-time update's bits on every lane set",
          "[shape][update_kernel]") {
  std::mt19937 rng(5);
  for (const bool shaped : {true, false}) {
    for (const float alpha : {0.0f, 0.7f, 1.0f}) {
      const std::size_t n = 61;
      const Case c = makeCase(rng, n);
      InsectUpdate u;
      u.x = {c.x.data(), c.y.data(), c.z.data()};
      u.v = {c.vx.data(), c.vy.data(), c.vz.data()};
      u.noise = {c.cnx.data(), c.cny.data(), c.cnz.data()};
      if (shaped) u.sample = {c.sx.data(), c.sy.data(), c.sz.data()};
      u.alpha = alpha;
      u.wDis = 2.5f;
      u.invRange = 1.0f / 1.7f;
      u.maxSpeed = 0.75f;
      u.dt = 1.0f / 30.0f;
      u.shaped = shaped;
      // the reference: the scalar update the model ran before the lanes
      std::vector<float> expect[6];
      for (auto& e : expect) e.resize(n);
      for (std::size_t k = 0; k < n; ++k) {
        const Vec3 x(c.x[k], c.y[k], c.z[k]);
        Vec3 v(c.vx[k], c.vy[k], c.vz[k]);
        const Vec3 internal = Vec3(c.fi[0][k], c.fi[1][k], c.fi[2][k]) + Vec3(c.cnx[k], c.cny[k], c.cnz[k]);
        Vec3 external = Vec3::Zero();
        if (shaped) {
          external += Vec3(c.fc[0][k], c.fc[1][k], c.fc[2][k]);
          external += distanceForce(x, Vec3(c.sx[k], c.sy[k], c.sz[k]), u.wDis, u.invRange);
        }
        const Vec3 force = alpha * internal + (1.0f - alpha) * external;
        v += force * u.dt;
        const float sp = v.norm();
        if (sp > u.maxSpeed) v *= u.maxSpeed / sp;
        for (int a = 0; a < 3; ++a) {
          expect[a][k] = v[a];
          expect[3 + a][k] = x[a] + v[a] * u.dt;
        }
      }
      // every split: a block of each length from each of a few offsets
      for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
        for (const std::size_t first : {std::size_t{0}, std::size_t{3}, std::size_t{17}}) {
          for (std::size_t count = 0; first + count <= n; ++count) {
            std::vector<float> got[6];
            for (auto& g : got) g.assign(n, 99.0f);
            u.nv = {got[0].data(), got[1].data(), got[2].data()};
            u.t = {got[3].data(), got[4].data(), got[5].data()};
            const float* fi[3] = {c.fi[0].data() + first, c.fi[1].data() + first, c.fi[2].data() + first};
            const float* fc[3] = {c.fc[0].data() + first, c.fc[1].data() + first, c.fc[2].data() + first};
            updateInsects(u, first, count, fi, fc, lanes);
            for (std::size_t k = 0; k < n; ++k) {
              for (int a = 0; a < 6; ++a) {
                CAPTURE(shaped, alpha, static_cast<int>(lanes), first, count, k, a, got[a][k], expect[a][k]);
                if (k >= first && k < first + count) {
                  REQUIRE(sameBits(got[a][k], expect[a][k]));
                } else {
                  REQUIRE(got[a][k] == 99.0f);  // nothing outside the block written
                }
              }
            }
          }
        }
      }
    }
  }
}

TEST_CASE("shape update: the sample points on SIMD lanes equal Eigen's placement of the interpolated samples",
          "[shape][update_kernel]") {
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-20.0f, 20.0f);
  const std::size_t samples = 500, n = 77;
  std::vector<Vec3> keyA(samples), keyB(samples);
  for (std::size_t i = 0; i < samples; ++i) {
    keyA[i] = Vec3(u(rng), u(rng), u(rng));
    keyB[i] = keyA[i] + Vec3(u(rng), u(rng), u(rng)) * 0.01f;
  }
  std::vector<std::uint32_t> sample(n);
  for (auto& s : sample) s = static_cast<std::uint32_t>(rng() % samples);
  sample[5] = samples - 1;  // the last sample: the gathers' reach
  const Eigen::Matrix3f rot = Eigen::AngleAxisf(0.7f, Vec3(0.2f, -0.3f, 0.9f).normalized()).toRotationMatrix();
  const Vec3 shift(31.5f, -2.25f, 7.0f), pivot(-12.0f, 3.5f, 0.125f);
  for (const bool placed : {true, false}) {
    for (const float f : {0.0f, 0.37f, 1.0f}) {
      TargetPlacement t;
      t.keyA = keyA.front().data();
      t.keyB = keyB.front().data();
      t.samples = samples;
      t.f = f;
      t.placed = placed;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) t.rot[3 * r + c] = rot(r, c);
        t.shift[r] = shift[r];
        t.pivot[r] = pivot[r];
      }
      for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
        for (const std::size_t first : {std::size_t{0}, std::size_t{5}}) {
          for (std::size_t count = 0; first + count <= n; ++count) {
            std::vector<float> got[3];
            for (auto& g : got) g.assign(n, 99.0f);
            placeTargets(t, sample.data(), first, count, got[0].data(), got[1].data(), got[2].data(), lanes);
            for (std::size_t k = 0; k < n; ++k) {
              const Vec3& a = keyA[sample[k]];
              const Vec3 p = a + f * (keyB[sample[k]] - a);
              const Vec3 want = placed ? Vec3(shift + rot * (p - pivot)) : p;
              for (int c = 0; c < 3; ++c) {
                CAPTURE(placed, f, static_cast<int>(lanes), first, count, k, c);
                if (k >= first && k < first + count) {
                  REQUIRE(sameBits(got[c][k], want[c]));
                } else {
                  REQUIRE(got[c][k] == 99.0f);
                }
              }
            }
          }
        }
      }
    }
  }
}

TEST_CASE("shape update: the step's end on SIMD lanes writes what the one-insect-at-a-time code writes",
          "[shape][update_kernel]") {
  // the scalar code of an insect that neither MDE nor an obstacle moves: x = t (+ 0), Eigen's clamp to the domain,
  // the state, the move, |v| and |target − x|
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  const std::size_t n = 53;
  std::vector<float> in[12];  // t, start, nv, target
  for (auto& a : in) {
    a.resize(n);
    for (float& v : a) v = u(rng);
  }
  const float lo[3] = {-1.5f, 0.0f, -1.0f}, hi[3] = {1.5f, 1.0f, -0.0f};
  for (std::size_t k = 0; k < n; k += 5) {   // signed zeros at the domain's zero faces and at the sums
    in[1][k] = -0.0f;                        // t.y = −0 against lo.y = +0
    in[2][k + 1 < n ? k + 1 : k] = 0.0f;     // t.z = +0 against hi.z = −0
    in[0][k] = -0.0f;                        // t.x = −0 inside the domain (+ 0 makes it +0)
    in[9][k] = in[0][k];                     // at its sample point along x
    in[6][k] = in[7][k] = in[8][k] = -0.0f;  // standing still
  }
  std::vector<std::uint32_t> ids(n);
  for (std::size_t k = 0; k < n; ++k) ids[k] = static_cast<std::uint32_t>(7 * k + 1);
  for (const bool addZero : {true, false}) {
    for (const bool shaped : {true, false}) {
      for (const bool withMove : {true, false}) {
        // expected, one insect at a time
        std::vector<float> want[8];  // p, v, speed, err
        for (auto& w : want) w.assign(n, 99.0f);
        for (std::size_t k = 0; k < n; ++k) {
          Vec3 x(in[0][k], in[1][k], in[2][k]);
          if (addZero) x += Vec3::Zero();
          x = x.cwiseMax(Vec3(lo[0], lo[1], lo[2])).cwiseMin(Vec3(hi[0], hi[1], hi[2]));
          const Vec3 v(in[6][k], in[7][k], in[8][k]);
          for (int a = 0; a < 3; ++a) {
            want[a][k] = x[a];
            want[3 + a][k] = v[a];
          }
          want[6][k] = v.norm();
          if (shaped) want[7][k] = (Vec3(in[9][k], in[10][k], in[11][k]) - x).norm();
        }
        for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
          for (const std::size_t first : {std::size_t{0}, std::size_t{3}, std::size_t{17}}) {
            for (std::size_t count = 0; first + count <= n; ++count) {
              std::vector<float> got[8];
              for (auto& g : got) g.assign(n, 99.0f);
              std::vector<float> move(3 * n, 99.0f);
              std::vector<std::uint32_t> id(n, 99u);
              std::vector<std::uint8_t> moved(n, 7u);
              InsectWrite w;
              w.t = {in[0].data(), in[1].data(), in[2].data()};
              w.start = {in[3].data(), in[4].data(), in[5].data()};
              w.nv = {in[6].data(), in[7].data(), in[8].data()};
              w.target = {in[9].data(), in[10].data(), in[11].data()};
              w.ids = ids.data();
              for (int a = 0; a < 3; ++a) {
                w.lo[a] = lo[a];
                w.hi[a] = hi[a];
              }
              w.addZero = addZero;
              w.shaped = shaped;
              w.p = {got[0].data(), got[1].data(), got[2].data()};
              w.v = {got[3].data(), got[4].data(), got[5].data()};
              w.speed = got[6].data();
              w.err = got[7].data();
              w.id = id.data();
              w.move = withMove ? move.data() : nullptr;
              w.moved = moved.data();
              writeInsects(w, first, count, lanes);
              for (std::size_t k = 0; k < n; ++k) {
                const bool inside = k >= first && k < first + count;
                CAPTURE(addZero, shaped, withMove, static_cast<int>(lanes), first, count, k);
                for (int a = 0; a < 8; ++a) {
                  CAPTURE(a, got[a][k], want[a][k]);
                  if (inside && (a != 7 || shaped)) {
                    REQUIRE(sameBits(got[a][k], want[a][k]));
                  } else {
                    REQUIRE(got[a][k] == 99.0f);
                  }
                }
                REQUIRE(id[k] == (inside ? ids[k] : 99u));
                REQUIRE(moved[k] == (inside ? 0u : 7u));
                for (int a = 0; a < 3; ++a) {
                  const float m = move[3 * k + static_cast<std::size_t>(a)];
                  CAPTURE(a, m);
                  if (inside && withMove) {
                    REQUIRE(sameBits(m, want[a][k] - in[3 + a][k]));
                  } else {
                    REQUIRE(m == 99.0f);
                  }
                }
              }
            }
          }
        }
      }
    }
  }
}
