#include "metrics/registry.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "metrics/full_reference.h"
#include "metrics/image_checks.h"
#include "metrics/no_reference.h"
#include "metrics/ssim.h"

namespace turbid {

struct OriginalCache {
  std::mutex mutex;
  const uchar* data = nullptr;  // which original (and at which range) the entries belong to
  cv::Size size;
  int type = -1;
  double range = 0.0;
  std::optional<VisibleEdgeOriginal> paper, ifsttar;
};

std::shared_ptr<OriginalCache> NewOriginalCache() { return std::make_shared<OriginalCache>(); }

namespace {

// Everything that more than one metric needs, computed at most once per ComputeMetrics call.
class SharedWork {
 public:
  explicit SharedWork(const MetricInputs& in) : in_(in) {}

  double Range() {
    if (in_.data_range > 0.0) return in_.data_range;
    const cv::Mat& any = !in_.image.empty() ? in_.image : in_.reference;
    return DefaultDataRange(any.empty() ? CV_32F : any.depth());
  }

  void RequirePair() {
    if (pair_checked_) return;
    if (in_.reference.empty())
      throw Error("metric needs a reference (ground-truth) image, none given");
    CheckMetricPair(in_.reference, in_.image, "score");
    if (in_.reference.depth() != in_.image.depth())
      throw Error("score: reference and image have different pixel depths");
    pair_checked_ = true;
  }

  double Mse() {
    if (!mse_) {
      RequirePair();
      mse_ = turbid::Mse(in_.reference, in_.image);
    }
    return *mse_;
  }

  double SsimMean() {
    if (!ssim_) {
      RequirePair();
      SsimOptions options;
      options.data_range = Range();
      if (Range() == 255.0 && in_.image.depth() != CV_8U) {
        // Raw 8-bit values held as float (the CLI): back to 8 bits, exact, for the fast kernel.
        ssim_ = Ssim(options, ForEightBitMetrics(in_.reference, &reference8_),
                     ForEightBitMetrics(in_.image, &image8_))
                    .mean;
      } else {
        ssim_ = Ssim(options, in_.reference, in_.image).mean;
      }
    }
    return *ssim_;
  }

  double CnrValue() {
    if (!cnr_) {
      CnrOptions options;
      options.data_range = Range();
      cnr_ = Cnr(options, in_.image).cnr;
    }
    return *cnr_;
  }

  // The no-reference metrics are defined on 8-bit values: hand them CV_8U when the data are raw
  // 8-bit values, [0,1] float otherwise (their documented input conventions).
  const cv::Mat& ForEightBitMetrics(const cv::Mat& src, cv::Mat* cache) {
    if (!cache->empty()) return *cache;
    const double range = Range();
    if (src.depth() == CV_8U || (range == 1.0 && src.depth() == CV_32F)) {
      *cache = src;
    } else if (range == 255.0) {
      CheckMetricImage(src, "score");
      src.convertTo(*cache, CV_8U);  // raw 8-bit values held as float: exact
    } else {
      CheckMetricImage(src, "score");
      src.convertTo(*cache, CV_32F, 1.0 / range);
    }
    return *cache;
  }

  const VisibleEdgeResult& Edges(VisibleEdgeVariant variant) {
    std::optional<VisibleEdgeResult>& slot =
        variant == VisibleEdgeVariant::kPaper ? edges_paper_ : edges_ifsttar_;
    if (!slot) {
      if (in_.original.empty())
        throw Error("visible-edge metrics need the original (degraded) image, none given");
      VisibleEdgeOptions options;
      options.variant = variant;
      OriginalCache* cache = in_.original_cache;
      if (cache == nullptr) {
        slot = VisibleEdges(options, ForEightBitMetrics(in_.original, &original8_),
                            ForEightBitMetrics(in_.image, &image8_));
      } else {
        std::unique_lock<std::mutex> lock(cache->mutex);
        if (cache->data != in_.original.data || cache->size != in_.original.size() ||
            cache->type != in_.original.type() || cache->range != Range()) {
          cache->paper.reset();
          cache->ifsttar.reset();
          cache->data = in_.original.data;
          cache->size = in_.original.size();
          cache->type = in_.original.type();
          cache->range = Range();
        }
        std::optional<VisibleEdgeOriginal>& analysis =
            variant == VisibleEdgeVariant::kPaper ? cache->paper : cache->ifsttar;
        if (!analysis)
          analysis =
              AnalyseVisibleEdgeOriginal(options, ForEightBitMetrics(in_.original, &original8_));
        const VisibleEdgeOriginal& original = *analysis;
        lock.unlock();  // entries are never replaced while the cache serves this original
        slot = VisibleEdges(options, original, ForEightBitMetrics(in_.image, &image8_));
      }
    }
    return *slot;
  }

  const UiqmResult& UiqmOf(UiqmVariant variant) {
    std::optional<UiqmResult>& slot =
        variant == UiqmVariant::kFunieGanCompat ? uiqm_compat_ : uiqm_corrected_;
    if (!slot) {
      UiqmOptions options;
      options.variant = variant;
      slot = Uiqm(options, ForEightBitMetrics(in_.image, &image8_));
    }
    return *slot;
  }

  double UciqeValue() {
    if (!uciqe_) uciqe_ = Uciqe({}, ForEightBitMetrics(in_.image, &image8_)).uciqe;
    return *uciqe_;
  }

 private:
  const MetricInputs& in_;
  bool pair_checked_ = false;
  std::optional<double> mse_, ssim_, cnr_, uciqe_;
  std::optional<VisibleEdgeResult> edges_paper_, edges_ifsttar_;
  std::optional<UiqmResult> uiqm_compat_, uiqm_corrected_;
  cv::Mat image8_, original8_, reference8_;
};

// The one metrics table: each entry carries its description and its compute, which reads the
// shared work (so metrics that share an analysis compute it once).
struct MetricEntry {
  MetricInfo info;  // {name, summary, needs_reference, needs_original, higher_is_better}
  double (*compute)(SharedWork& work);
};

using V = VisibleEdgeVariant;
constexpr UiqmVariant kFunie = UiqmVariant::kFunieGanCompat;

const std::vector<MetricEntry>& MetricTable() {
  static const std::vector<MetricEntry> table = {
      {{"ssim", "SSIM, Wang 2004 Gaussian 11x11 s=1.5; = scikit-image 0.19 to 1e-6", true, false,
        true},
       [](SharedWork& w) { return w.SsimMean(); }},
      {{"psnr", "PSNR in dB over all pixels and channels; = scikit-image to 1e-9 rel; inf if equal",
        true, false, true},
       [](SharedWork& w) { return PsnrFromMse(w.Mse(), w.Range()); }},
      {{"mse", "mean squared error on the [0,1] scale (x data_range^2 on raw scale)", true, false,
        false},
       // On the [0,1] scale whatever the input scale.
       [](SharedWork& w) { return w.Mse() / (w.Range() * w.Range()); }},
      {{"cnr", "contrast-to-noise ratio between Otsu classes of the luma (docs/metrics.md)", false,
        false, true},
       [](SharedWork& w) { return w.CnrValue(); }},
      {{"hautiere_e", "Hautiere 2008 rate of new visible edges e (paper variant)", false, true,
        true},
       [](SharedWork& w) { return w.Edges(V::kPaper).e; }},
      {{"hautiere_r", "Hautiere 2008 geometric mean gradient ratio r (paper variant)", false, true,
        true},
       [](SharedWork& w) { return w.Edges(V::kPaper).r_mean; }},
      {{"hautiere_sigma", "Hautiere 2008 saturated fraction sigma, black+white (paper variant)",
        false, true, false},
       [](SharedWork& w) { return w.Edges(V::kPaper).sigma; }},
      {{"hautiere_m", "source paper's Table I 'm': black-pixel fraction as the IFSTTAR code", false,
        true, true},
       [](SharedWork& w) { return w.Edges(V::kPaper).m; }},
      {{"hautiere_e_ifsttar", "e as the published IFSTTAR MATLAB code", false, true, true},
       [](SharedWork& w) { return w.Edges(V::kIfsttar).e; }},
      {{"hautiere_r_ifsttar", "r as the published IFSTTAR MATLAB code", false, true, true},
       [](SharedWork& w) { return w.Edges(V::kIfsttar).r_mean; }},
      {{"hautiere_sigma_ifsttar", "sigma as the IFSTTAR code (black only on 8-bit)", false, true,
        false},
       [](SharedWork& w) { return w.Edges(V::kIfsttar).sigma; }},
      {{"uiqm", "UIQM, Panetta 2016; = FUnIE-GAN uqim_utils.py", false, false, true},
       [](SharedWork& w) { return w.UiqmOf(kFunie).uiqm; }},
      {{"uicm", "UIQM colourfulness term (FUnIE-GAN)", false, false, true},
       [](SharedWork& w) { return w.UiqmOf(kFunie).uicm; }},
      {{"uism", "UIQM sharpness term (FUnIE-GAN)", false, false, true},
       [](SharedWork& w) { return w.UiqmOf(kFunie).uism; }},
      {{"uiconm", "UIQM contrast term (FUnIE-GAN)", false, false, true},
       [](SharedWork& w) { return w.UiqmOf(kFunie).uiconm; }},
      {{"uiqm_corrected", "UIQM with the trimmed-mean and lambda_B bugs fixed", false, false, true},
       [](SharedWork& w) { return w.UiqmOf(UiqmVariant::kCorrected).uiqm; }},
      {{"uciqe", "UCIQE, Yang & Sowmya 2015; = JOU-UIP UCIQE.py", false, false, true},
       [](SharedWork& w) { return w.UciqeValue(); }},
  };
  return table;
}

const MetricEntry& FindEntry(const std::string& name) {
  for (const MetricEntry& entry : MetricTable())
    if (entry.info.name == name) return entry;
  std::string known;
  for (const MetricEntry& entry : MetricTable())
    known += (known.empty() ? "" : ", ") + entry.info.name;
  throw Error("unknown metric '" + name + "' (known: " + known + ")");
}

}  // namespace

const std::vector<MetricInfo>& ListMetrics() {
  static const std::vector<MetricInfo> metrics = [] {
    std::vector<MetricInfo> out;
    for (const MetricEntry& entry : MetricTable()) out.push_back(entry.info);
    return out;
  }();
  return metrics;
}

const MetricInfo& FindMetric(const std::string& name) {
  return ListMetrics()[&FindEntry(name) - MetricTable().data()];  // the listed entry itself
}

std::map<std::string, double> ComputeMetrics(const std::vector<std::string>& names,
                                             const MetricInputs& inputs,
                                             std::map<std::string, double>* elapsed_ms) {
  for (const std::string& name : names) FindMetric(name);  // all names valid before any work
  if (inputs.image.empty()) throw Error("score: the image to score is empty");
  if (inputs.data_range < 0.0 || !std::isfinite(inputs.data_range))
    throw Error("score: data_range must be >= 0");
  SharedWork work(inputs);
  std::map<std::string, double> values;
  for (const std::string& name : names) {
    if (values.count(name)) continue;
    if (elapsed_ms == nullptr) {
      values[name] = FindEntry(name).compute(work);
      continue;
    }
    const auto start = std::chrono::steady_clock::now();
    values[name] = FindEntry(name).compute(work);
    (*elapsed_ms)[name] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return values;
}

nlohmann::json MetricValueToJson(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  return value;
}

std::string MetricValueToText(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.10g", value);
  return buffer;
}

std::vector<std::string> ParseMetricList(const std::string& list, bool has_reference,
                                         bool has_original) {
  std::vector<std::string> names;
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t a = item.find_first_not_of(" \t");
    const size_t b = item.find_last_not_of(" \t");
    if (a == std::string::npos) continue;
    item = item.substr(a, b - a + 1);
    if (item == "all") {
      for (const MetricInfo& info : ListMetrics())
        if ((!info.needs_reference || has_reference) && (!info.needs_original || has_original))
          names.push_back(info.name);
      continue;
    }
    const MetricInfo& info = FindMetric(item);
    if (info.needs_reference && !has_reference)
      throw Error("metric '" + item + "' needs a reference image (--ref)");
    if (info.needs_original && !has_original)
      throw Error("metric '" + item + "' needs the original degraded image (--original)");
    names.push_back(item);
  }
  if (names.empty()) throw Error("no metrics requested (empty --metrics list)");
  // Keep the first occurrence of each name, in the order given.
  std::vector<std::string> unique;
  for (const std::string& n : names)
    if (std::find(unique.begin(), unique.end(), n) == unique.end()) unique.push_back(n);
  return unique;
}

}  // namespace turbid
