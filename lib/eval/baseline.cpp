#include "eval/baseline.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"

namespace swarmsim::eval {
namespace {

std::string numberText(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

// a positive finite number, else InputError naming the field
void requirePositive(const char* field, double v, const char* unit) {
  if (!(v > 0.0) || !std::isfinite(v)) {
    throw InputError(std::string("baseline spec: ") + field + " must be a finite number > 0 (" + unit + "), got " +
                     numberText(v));
  }
}

void validate(const BaselineSpec& spec) {
  // ids are the agent words of AgentRng (32 bits)
  constexpr std::int64_t kMaxCount = std::int64_t{1} << 32;
  if (spec.count <= 0 || spec.count > kMaxCount) {
    throw InputError("baseline spec: count must be in [1, " + std::to_string(kMaxCount) + "], got " +
                     std::to_string(spec.count));
  }
  if (spec.samples <= 0) throw InputError("baseline spec: samples must be > 0, got " + std::to_string(spec.samples));
  requirePositive("dt", spec.dt, "s");
  requirePositive("medianSpeed", spec.medianSpeed, "m/s");
  requirePositive("correlationTime", spec.correlationTime, "s");
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(spec.centre[static_cast<std::size_t>(c)])) {
      throw InputError("baseline spec: centre[" + std::to_string(c) + "] must be a finite number (m), got " +
                       numberText(spec.centre[static_cast<std::size_t>(c)]));
    }
  }
  requirePositive("extent", spec.extent, "m");
}

class OuBaseline final : public TrackSource {
 public:
  explicit OuBaseline(const BaselineSpec& spec) : spec_(spec), n_(static_cast<std::size_t>(spec.count)) {
    s_ = spec.medianSpeed / maxwellMedianFactor();
    const double tau = spec.correlationTime;
    a_ = std::exp(-spec.dt / tau);
    noise_ = s_ * std::sqrt(-std::expm1(-2.0 * spec.dt / tau));  // s sqrt(1 - a^2), accurate for dt << tau
    kappa_ = s_ * s_ / (spec.extent * spec.extent / 3.0);
    posStd_ = spec.extent / std::sqrt(3.0);
    if (!std::isfinite(s_) || !std::isfinite(kappa_) || !(kappa_ > 0.0)) {
      throw InputError("baseline spec: medianSpeed " + numberText(spec.medianSpeed) + " m/s, extent " +
                       numberText(spec.extent) + " m and correlationTime " + numberText(tau) +
                       " s give no usable process (out of the range of doubles)");
    }
    // the explicit spring step is stable iff kappa dt^2 < 2 (1 + a) (baseline.hpp)
    const double bound = 2.0 * (1.0 + a_);
    if (!(kappa_ * spec.dt * spec.dt < bound)) {
      throw InputError(
          "baseline spec: dt " + numberText(spec.dt) +
          " s is too long for the walkers' spring (kappa dt^2 = " + numberText(kappa_ * spec.dt * spec.dt) +
          ", must be < 2 (1 + exp(-dt/tau)) = " + numberText(bound) + "): a walker would move about the whole extent " +
          numberText(spec.extent) + " m per sample; the integration would diverge");
    }
    info_.file = "baseline (Ornstein-Uhlenbeck)";
    info_.kind = "baseline";
    info_.dt = spec.dt;
    info_.individuals = spec.count;
    info_.hasVelocity = true;
    info_.first = 0;
    info_.last = spec.samples;
  }

  void read(std::int64_t k, Frame& out) override {
    if (k < info_.first || k >= info_.last) {
      throw std::out_of_range("baseline: sample " + std::to_string(k) + " outside [0, " + std::to_string(info_.last) +
                              ")");
    }
    if (current_ < 0 || k < current_) start();
    if (k > current_) advance(k);
    out.sample = k;
    out.dense = true;
    out.id.resize(n_);
    for (std::size_t i = 0; i < n_; ++i) out.id[i] = static_cast<std::int64_t>(i);
    out.pos = pos_;
    out.vel = vel_;
  }

 private:
  // sample 0: every individual in the stationary distribution
  void start() {
    pos_.resize(3 * n_);
    vel_.resize(3 * n_);
    parallelFor(n_, [&](std::size_t i) {
      AgentRng rng(spec_.seed, 0, static_cast<std::uint32_t>(i), RngPurpose::kBaseline);
      const Vec3 p = rng.normal3();
      const Vec3 v = rng.normal3();
      for (int c = 0; c < 3; ++c) {
        const auto j = static_cast<std::size_t>(c);
        pos_[3 * i + j] = spec_.centre[j] + posStd_ * static_cast<double>(p[c]);
        vel_[3 * i + j] = s_ * static_cast<double>(v[c]);
      }
    });
    current_ = 0;
  }

  // steps every individual from sample current_ to sample k (> current_)
  void advance(std::int64_t k) {
    const std::int64_t from = current_;
    const double dt = spec_.dt;
    parallelFor(n_, [&](std::size_t i) {
      double x[3], v[3];
      for (std::size_t c = 0; c < 3; ++c) {
        x[c] = pos_[3 * i + c];
        v[c] = vel_[3 * i + c];
      }
      for (std::int64_t m = from + 1; m <= k; ++m) {
        AgentRng rng(spec_.seed, static_cast<std::uint64_t>(m), static_cast<std::uint32_t>(i), RngPurpose::kBaseline);
        const Vec3 xi = rng.normal3();
        for (std::size_t c = 0; c < 3; ++c) {
          v[c] = a_ * v[c] + noise_ * static_cast<double>(xi[static_cast<int>(c)]) -
                 kappa_ * (x[c] - spec_.centre[c]) * dt;
          x[c] += v[c] * dt;
        }
      }
      for (std::size_t c = 0; c < 3; ++c) {
        pos_[3 * i + c] = x[c];
        vel_[3 * i + c] = v[c];
      }
    });
    current_ = k;
  }

  BaselineSpec spec_;
  std::size_t n_;
  double s_ = 0.0, a_ = 0.0, noise_ = 0.0, kappa_ = 0.0, posStd_ = 0.0;
  std::int64_t current_ = -1;  // the sample pos_/vel_ hold; -1: not started
  std::vector<double> pos_, vel_;
};

}  // namespace

double maxwellMedianFactor() {
  static const double factor = [] {
    // CDF of the chi distribution with 3 degrees of freedom, increasing in m
    const auto cdf = [](double m) {
      return std::erf(m / std::sqrt(2.0)) - std::sqrt(2.0 / 3.14159265358979323846) * m * std::exp(-0.5 * m * m);
    };
    double lo = 0.0, hi = 5.0;  // cdf(0) = 0, cdf(5) > 0.99
    for (int it = 0; it < 200 && hi - lo > 0.0; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (cdf(mid) < 0.5 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  }();
  return factor;
}

std::unique_ptr<TrackSource> makeOuBaseline(const BaselineSpec& spec) {
  validate(spec);
  return std::make_unique<OuBaseline>(spec);
}

}  // namespace swarmsim::eval
