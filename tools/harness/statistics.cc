#include "tools/harness/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "tools/harness/experiment.h"

namespace turbid {

double SortedQuantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::nan("");
  const double h = q * static_cast<double>(sorted.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(h));
  const size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

Interval BootstrapMeanCi(const std::vector<double>& all, uint64_t seed, int resamples,
                         double level) {
  std::vector<double> values;
  for (double v : all)
    if (!std::isnan(v)) values.push_back(v);
  const size_t n = values.size();
  if (n == 0) return {std::nan(""), std::nan("")};
  const double mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(n);
  const bool constant =
      std::all_of(values.begin(), values.end(), [&](double v) { return v == values.front(); });
  if (!std::isfinite(mean) || constant || n == 1) return {mean, mean};
  std::vector<double> means(static_cast<size_t>(resamples));
  const double scale = static_cast<double>(n) / 9007199254740992.0;  // n / 2^53
  for (int r = 0; r < resamples; ++r) {
    const uint64_t stream = MixSeed(seed ^ MixSeed(static_cast<uint64_t>(r)));
    double sum = 0.0;
    for (size_t k = 0; k < n; ++k) {
      const uint64_t bits = MixSeed(stream + k) >> 11;  // 53 random bits
      const size_t index = std::min(n - 1, static_cast<size_t>(static_cast<double>(bits) * scale));
      sum += values[index];
    }
    means[static_cast<size_t>(r)] = sum / static_cast<double>(n);
  }
  std::sort(means.begin(), means.end());
  return {SortedQuantile(means, (1.0 - level) / 2.0), SortedQuantile(means, (1.0 + level) / 2.0)};
}

SignedRankResult WilcoxonSignedRank(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    if (std::isnan(a[i]) || std::isnan(b[i])) continue;
    const double diff = a[i] - b[i];
    if (diff != 0.0 && !std::isnan(diff)) d.push_back(diff);
  }
  SignedRankResult out;
  out.n = static_cast<int>(d.size());
  if (d.empty()) return out;
  // Mean ranks of |d| (ties share); held doubled so that every rank is an integer.
  std::vector<size_t> order(d.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](size_t i, size_t j) { return std::fabs(d[i]) < std::fabs(d[j]); });
  std::vector<int> rank2(d.size());
  double tie_term = 0.0;  // sum of t^3 - t over tie groups
  for (size_t i = 0; i < order.size();) {
    size_t j = i;
    while (j + 1 < order.size() && std::fabs(d[order[j + 1]]) == std::fabs(d[order[i]])) ++j;
    const int doubled = static_cast<int>(i + j + 2);  // 2 x mean of ranks i+1 .. j+1
    for (size_t k = i; k <= j; ++k) rank2[order[k]] = doubled;
    const double t = static_cast<double>(j - i + 1);
    tie_term += t * t * t - t;
    i = j + 1;
  }
  int w2 = 0, total2 = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    total2 += rank2[i];
    if (d[i] > 0) w2 += rank2[i];
  }
  out.w_plus = w2 / 2.0;
  const double n = static_cast<double>(d.size());
  if (d.size() <= 50) {
    // count[s]: sign assignments whose doubled positive-rank sum is s (each of 2^n equally likely).
    std::vector<double> count(static_cast<size_t>(total2) + 1, 0.0);
    count[0] = 1.0;
    int reach = 0;
    for (int r : rank2) {
      for (int s = reach; s >= 0; --s)
        if (count[static_cast<size_t>(s)] != 0.0)
          count[static_cast<size_t>(s + r)] += count[static_cast<size_t>(s)];
      reach += r;
    }
    double below = 0.0, above = 0.0;  // P(W <= w), P(W >= w) in counts
    for (int s = 0; s <= total2; ++s) {
      if (s <= w2) below += count[static_cast<size_t>(s)];
      if (s >= w2) above += count[static_cast<size_t>(s)];
    }
    const double all = std::pow(2.0, n);
    out.p_value = std::min(1.0, 2.0 * std::min(below, above) / all);
    out.exact = true;
    return out;
  }
  const double mean = n * (n + 1.0) / 4.0;
  const double var = n * (n + 1.0) * (2.0 * n + 1.0) / 24.0 - tie_term / 48.0;
  const double z = var > 0.0 ? std::fabs(out.w_plus - mean) / std::sqrt(var) : 0.0;
  out.p_value = std::min(1.0, std::erfc(z / std::sqrt(2.0)));
  out.exact = false;
  return out;
}

uint64_t StableHash(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace turbid
