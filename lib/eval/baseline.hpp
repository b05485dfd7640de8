#pragma once
// A baseline swarm for `swarmsim evaluate`: independent random walkers matched
// to a reference data set, served as an in-memory TrackSource, so that a report
// can show where plain noise lands on every metric.
//
// Process. Every individual, on every axis independently, is a Langevin
// oscillator around the centre c (an Ornstein-Uhlenbeck velocity tied to the
// centre by a weak spring):
//     dv = -(1/tau) v dt - kappa (x - c) dt + sigma dW,     dx = v dt.
// Individuals do not interact: the baseline has no alignment, no cohesion
// other than the common spring, no collision avoidance.
//
// Matching the spec (s = per-axis velocity standard deviation):
//   medianSpeed     the speed |v| of an isotropic 3-D Gaussian velocity of
//                   per-axis std s is s times a chi variable with 3 degrees of
//                   freedom (Maxwell distribution), whose median m3 solves
//                   erf(m/sqrt 2) - sqrt(2/pi) m exp(-m^2/2) = 1/2:
//                   m3 = 1.5381722544550522... (maxwellMedianFactor() solves it
//                   by bisection once). So s = medianSpeed / m3.
//   correlationTime tau is the OU friction time; sigma^2 = 2 s^2 / tau keeps
//                   the stationary velocity variance at s^2.
//   extent          the stationary position variance per axis is s^2 / kappa,
//                   so kappa = s^2 / (extent^2 / 3) gives a root-mean-square
//                   distance to the centre of extent (3 axes).
//
// Integration, from sample k to k + 1 (per axis, xi a standard normal draw):
//     a = exp(-dt/tau)
//     v <- a v + s sqrt(1 - a^2) xi - kappa (x - c) dt    (the exact OU step for
//                                                          friction and noise,
//                                                          the spring explicitly)
//     x <- x + v dt                                        (semi-implicit Euler)
// Sample 0 is drawn from the stationary distribution of the continuous
// process (x - c ~ N(0, extent^2/3), v ~ N(0, s^2) per axis, independent), so
// there is no warm-up. The frames serve x and v of each sample.
//
// What the numbers are (for the test spec: medianSpeed 0.47 m/s, tau 0.25 s,
// extent 0.3 m, dt 0.02 s: s = 0.3056 m/s, sigma = 0.864 m/s^1.5,
// kappa = 3.112 1/s^2):
//   * The spring bends the velocity autocorrelation away from exp(-t/tau).
//     The exact one of the continuous process is
//         C(t) = exp(-t/(2 tau)) [cosh(w t) - sinh(w t) / (2 w tau)],
//         w = sqrt(1/(4 tau^2) - kappa)
//     (cos/sin with w = sqrt(kappa - 1/(4 tau^2)) when kappa tau^2 > 1/4,
//     underdamped); it goes negative eventually, since the position stays
//     bounded. C = exp(-t/tau) only when kappa tau^2 << 1. Where C drops to
//     1/e, as a fraction of tau: kappa tau^2 = 0.0175 (extent 1 m, the rest as above):
//     -1.2 %; 0.031 (tau 0.1 s): -2.1 %; 0.19 (the test spec): -11 %
//     (0.222 s instead of 0.25 s); 0.78 (tau 0.5 s): -28 %. The spec's
//     correlationTime is the friction time tau, not that 1/e time.
//   * The discrete chain's stationary statistics differ slightly from the
//     continuous ones it starts in (the explicit spring step): for the test
//     spec the velocity std is +0.02 % off, the position std -1.9 %, and x and
//     v get a correlation of 0.018; at dt = 0.2 s, -13 % for the position std.
//     The median speed is the best matched of the three.
//   * Stability: the step's matrix on (x, v) has determinant a and trace
//     1 + a - kappa dt^2, so the chain is stable iff kappa dt^2 < 2 (1 + a),
//     i.e. s dt < extent sqrt(2 (1 + a) / 3), between 0.82 and 1.15 extent: a
//     walker must move less than about the extent per sample. A spec beyond
//     that bound is refused (InputError naming dt): its positions would grow
//     without bound. Well inside it the bias above is what remains.
//
// Random numbers are counter-based (AgentRng, RngPurpose::kBaseline, stream
// 0), keyed on (seed, sample, individual): sample 0 draws the initial position
// and velocity (two normal3), sample k >= 1 the noise of the step from k - 1 to
// k (one normal3). The output is therefore a pure function of the spec,
// independent of the thread count and of how it is read; a pass that goes
// back (read(k) with k lower than the last sample read) regenerates the
// process from sample 0.
#include <array>
#include <cstdint>
#include <memory>

#include "eval/tracks.hpp"

namespace swarmsim::eval {

struct BaselineSpec {
  std::int64_t count = 0;          // individuals, all present in every sample (> 0)
  std::int64_t samples = 0;        // samples of the time grid (> 0)
  double dt = 0.0;                 // s, sampling interval (> 0)
  double medianSpeed = 0.0;        // m/s, asked median of |v| over all individuals and samples (> 0)
  double correlationTime = 0.0;    // s, asked velocity autocorrelation time tau (> 0): C(t) ~ exp(-t/tau)
  std::array<double, 3> centre{};  // m, the point the walkers stay around
  double extent = 0.0;             // m, asked root-mean-square distance to the centre (> 0)
  std::uint64_t seed = 0;
};

// the median of the chi distribution with 3 degrees of freedom (the Maxwell
// speed distribution of unit per-axis std): 1.5381722544550522...
double maxwellMedianFactor();

// Throws InputError (core/error.hpp) naming the bad field for a spec that is not valid.
// The source has info(): file "baseline (Ornstein-Uhlenbeck)", kind "baseline",
// dt, individuals = count, hasVelocity, samples [0, samples); every frame is
// dense with ids 0..count-1.
std::unique_ptr<TrackSource> makeOuBaseline(const BaselineSpec& spec);

}  // namespace swarmsim::eval
