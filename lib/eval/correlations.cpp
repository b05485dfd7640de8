#include "eval/correlations.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace swarmsim::eval {

void CorrelationSums::resize(int lags, int bins) {
  autoNum.assign(static_cast<std::size_t>(lags) + 1, 0.0);
  autoDen.assign(static_cast<std::size_t>(lags) + 1, 0.0);
  pairSum.assign(static_cast<std::size_t>(bins), 0.0);
  pairCount.assign(static_cast<std::size_t>(bins), 0.0);
}

void CorrelationSums::add(const CorrelationSums& o) {
  for (std::size_t i = 0; i < autoNum.size(); ++i) {
    autoNum[i] += o.autoNum[i];
    autoDen[i] += o.autoDen[i];
  }
  for (std::size_t i = 0; i < pairSum.size(); ++i) {
    pairSum[i] += o.pairSum[i];
    pairCount[i] += o.pairCount[i];
  }
}

CorrelationAccumulator::CorrelationAccumulator(double dt, std::int64_t first, std::int64_t last, int blocks)
    : first_(first), last_(last) {
  lags_ = dt > 0 ? static_cast<int>(std::min<double>(kMaxLags, std::ceil(kAutoSeconds / dt - 1e-9))) : 1;
  lags_ = std::max(lags_, 1);
  ring_.resize(static_cast<std::size_t>(lags_) + 1);
  blocks_.resize(static_cast<std::size_t>(std::max(blocks, 1)));
  for (auto& b : blocks_) b.resize(lags_, kDistanceBins);
}

int blockOfSample(std::int64_t sample, std::int64_t first, std::int64_t last, int blocks) {
  const std::int64_t span = std::max<std::int64_t>(1, last - first);
  return static_cast<int>(std::clamp<std::int64_t>((sample - first) * blocks / span, 0, blocks - 1));
}

int CorrelationAccumulator::blockOf(std::int64_t sample) const {
  return blockOfSample(sample, first_, last_, static_cast<int>(blocks_.size()));
}

void CorrelationAccumulator::add(const SampleView& s) {
  const Frame& f = *s.frame;
  const std::vector<double>& v = *s.velocity;
  const std::size_t n = f.size();
  const std::size_t stride = std::max<std::size_t>(1, (n + kMaxRows - 1) / kMaxRows);
  // the mean velocity of the sample and the taken rows' fluctuations
  double mean[3] = {0, 0, 0};
  std::size_t withV = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(v[3 * i])) continue;
    for (std::size_t d = 0; d < 3; ++d) mean[d] += v[3 * i + d];
    ++withV;
  }
  if (withV > 0) {
    for (double& m : mean) m /= static_cast<double>(withV);
  }
  Past& now = ring_[static_cast<std::size_t>(s.sample % static_cast<std::int64_t>(ring_.size()))];
  now.sample = s.sample;
  now.id.clear();
  now.dv.clear();
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < n; i += stride) {
    now.id.push_back(f.id[i]);
    rows.push_back(i);
    for (std::size_t d = 0; d < 3; ++d) {
      now.dv.push_back(std::isnan(v[3 * i]) ? std::numeric_limits<double>::quiet_NaN() : v[3 * i + d] - mean[d]);
    }
  }

  // autocorrelation: this sample against each earlier one still in the ring (the pair counts in the block of
  // the earlier sample)
  for (int lag = 0; lag <= lags_; ++lag) {
    const std::int64_t t = s.sample - lag;
    if (t < first_) break;
    const Past& past = ring_[static_cast<std::size_t>(t % static_cast<std::int64_t>(ring_.size()))];
    if (past.sample != t) continue;
    CorrelationSums& sums = blocks_[static_cast<std::size_t>(blockOf(t))];
    double num = 0, den = 0;
    std::size_t a = 0, b = 0;  // both id lists ascending: merge
    while (a < past.id.size() && b < now.id.size()) {
      if (past.id[a] < now.id[b]) {
        ++a;
      } else if (now.id[b] < past.id[a]) {
        ++b;
      } else {
        const double* p = &past.dv[3 * a];
        const double* q = &now.dv[3 * b];
        if (!std::isnan(p[0]) && !std::isnan(q[0])) {
          num += p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
          den += p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        }
        ++a;
        ++b;
      }
    }
    sums.autoNum[static_cast<std::size_t>(lag)] += num;
    sums.autoDen[static_cast<std::size_t>(lag)] += den;
  }

  // velocity correlation over distance, in units of the sample's length per individual
  if (n < 3) return;
  const double* p = f.pos.data();
  double c[3], spacing = 0;
  centroidAndSpacing(f, c, spacing);
  if (!(spacing > 0.0)) return;
  const double binWidth = kMaxDistance / kDistanceBins;
  std::vector<double> u(3 * rows.size());
  std::vector<char> ok(rows.size(), 0);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const double* q = &now.dv[3 * k];
    const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    if (std::isnan(len) || len == 0.0) continue;
    ok[k] = 1;
    for (std::size_t d = 0; d < 3; ++d) u[3 * k + d] = q[d] / len;
  }
  CorrelationSums& sums = blocks_[static_cast<std::size_t>(blockOf(s.sample))];
  for (std::size_t a = 0; a < rows.size(); ++a) {
    if (!ok[a]) continue;
    const double* pa = &p[3 * rows[a]];
    for (std::size_t b = a + 1; b < rows.size(); ++b) {
      if (!ok[b]) continue;
      const double* pb = &p[3 * rows[b]];
      const double dx = pb[0] - pa[0], dy = pb[1] - pa[1], dz = pb[2] - pa[2];
      const double r = std::sqrt(dx * dx + dy * dy + dz * dz) / spacing;
      const int bin = static_cast<int>(r / binWidth);
      if (bin >= kDistanceBins) continue;
      const double dot = u[3 * a] * u[3 * b] + u[3 * a + 1] * u[3 * b + 1] + u[3 * a + 2] * u[3 * b + 2];
      sums.pairSum[static_cast<std::size_t>(bin)] += 2.0 * dot;  // the pair (a, b) and (b, a)
      sums.pairCount[static_cast<std::size_t>(bin)] += 2.0;
    }
  }
}

std::vector<double> ratio(const std::vector<double>& num, const std::vector<double>& den) {
  std::vector<double> r(num.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < num.size(); ++i) {
    if (den[i] > 0) r[i] = num[i] / den[i];
  }
  return r;
}

double correlationTime(const std::vector<double>& c, double dt) {
  const double target = std::exp(-1.0);
  for (std::size_t k = 1; k < c.size(); ++k) {
    if (std::isnan(c[k]) || std::isnan(c[k - 1])) return std::numeric_limits<double>::quiet_NaN();
    if (c[k] < target) {
      const double f = (c[k - 1] - target) / (c[k - 1] - c[k]);
      return (static_cast<double>(k - 1) + f) * dt;
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace swarmsim::eval
