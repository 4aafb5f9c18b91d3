#include "tools/harness/sweep_sequence.h"

#include <algorithm>
#include <limits>
#include <set>
#include <tuple>

#include "core/error.h"

namespace turbid {
namespace {
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
}  // namespace

SequenceScorer::SequenceScorer(const Experiment& experiment, StageProfile* profile)
    : experiment_(experiment), profile_(profile) {
  std::set<int> skips;
  std::set<FeatureDetector> detectors;
  for (const HarnessMetricInfo& info : experiment.metrics) {
    if (!info.sequence) continue;
    const std::optional<FrontendMetric> metric = ParseFrontendMetric(info.name);
    if (!metric) throw Error("metric '" + info.name + "' is not a front-end metric");
    metrics_.push_back(*metric);
    skips.insert(metric->skip);
    if (metric->base != "flicker") {
      detectors.insert(metric->detector);
      parts_[metric->detector] |= FrontendPartOf(metric->base);
    }
  }
  skips_.assign(skips.begin(), skips.end());
  detectors_.assign(detectors.begin(), detectors.end());
  for (const ExperimentScene& scene : experiment.scenes) scene_frames_.push_back(scene.frames);
}

std::shared_ptr<const FrameRecord> SequenceScorer::Build(
    const Scene& frame, const Pose& pose, const CameraCoding& camera,
    const std::map<std::string, cv::Mat>& images) const {
  const ScopedStage timed(profile_, "front end: luma and features");
  auto record = std::make_shared<FrameRecord>();
  for (const auto& [label, image] : images) {
    FrontendFrame f;
    f.gray8 = ToGray8(EncodeForScoring(image, camera), camera.DataRange());
    f.depth_m = frame.depth_m;
    f.camera = frame.camera;
    f.pose = pose;
    for (FeatureDetector detector : detectors_)
      f.features[detector] = DetectFrontendFeatures(options_, detector, f.gray8);
    record->frames.emplace(label, std::move(f));
  }
  return record;
}

int SequenceScorer::Consumers(const ItemSpec& spec) const {
  const int frames = scene_frames_.at(static_cast<size_t>(spec.scene_index));
  int count = 0;
  for (int k : skips_) count += spec.frame + k < frames;
  return count;
}

bool SequenceScorer::Claim(const ItemSpec& spec) {
  const int index = spec.index;
  std::lock_guard<std::mutex> lock(mutex_);
  if (entries_.count(index)) return false;
  Entry entry;
  entry.promise = std::make_shared<std::promise<std::shared_ptr<const FrameRecord>>>();
  entry.future = entry.promise->get_future().share();
  entry.consumers = Consumers(spec);
  entries_.emplace(index, std::move(entry));
  return true;
}

void SequenceScorer::Publish(int index, std::shared_ptr<const FrameRecord> record) {
  std::shared_ptr<std::promise<std::shared_ptr<const FrameRecord>>> promise;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(index);
    if (it == entries_.end() || !it->second.promise) return;
    promise = std::move(it->second.promise);
    // Failed, or no frame pairs with it: whoever needs the frame computes it.
    if (!record || it->second.consumers == 0) entries_.erase(it);
  }
  promise->set_value(std::move(record));
}

std::shared_ptr<const FrameRecord> SequenceScorer::Take(
    int index, const std::function<std::shared_ptr<const FrameRecord>()>& compute) {
  std::shared_future<std::shared_ptr<const FrameRecord>> future;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(index);
    if (it != entries_.end()) future = it->second.future;
  }
  std::shared_ptr<const FrameRecord> record;
  if (future.valid()) record = future.get();
  if (record) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(index);
    if (it != entries_.end() && it->second.consumers > 0 && --it->second.consumers == 0)
      entries_.erase(it);
    return record;
  }
  return compute();
}

void SequenceScorer::Score(
    const ItemSpec& item, const FrameRecord& own,
    const std::function<std::shared_ptr<const FrameRecord>(int index)>& record_of,
    ItemResult* result) const {
  std::map<int, std::shared_ptr<const FrameRecord>> previous;  // by skip
  for (int k : skips_) {
    if (item.frame >= k) previous[k] = record_of(item.index - k);
  }
  const ScopedStage timed(profile_, "front end: pairs and pose");
  // Pair values per (skip, detector, label) and temporal differences per (skip, label).
  std::map<std::tuple<int, FeatureDetector, std::string>, FrontendPair> pairs;
  std::map<std::pair<int, std::string>, double> differences;
  std::map<int, TemporalWarp> warps;  // by skip: depth and poses only, shared by every label
  const auto pair_of = [&](int k, FeatureDetector detector, const std::string& label,
                           const FrameRecord& before) -> const FrontendPair* {
    const auto a = before.frames.find(label);
    const auto b = own.frames.find(label);
    if (a == before.frames.end() || b == own.frames.end()) return nullptr;
    const auto key = std::make_tuple(k, detector, label);
    auto it = pairs.find(key);
    if (it == pairs.end())
      it = pairs
               .emplace(key, EvaluateFrontendPair(options_, detector, a->second, b->second,
                                                  parts_.at(detector)))
               .first;
    return &it->second;
  };
  const auto difference_of = [&](int k, const std::string& label, const FrameRecord& before) {
    const auto a = before.frames.find(label);
    const auto b = own.frames.find(label);
    if (a == before.frames.end() || b == own.frames.end()) return kNan;
    const auto key = std::make_pair(k, label);
    auto it = differences.find(key);
    if (it == differences.end()) {
      auto warp = warps.find(k);
      if (warp == warps.end()) {
        // The clean frames' depth, cameras and poses: the same in every label's frame.
        const FrontendFrame& clean_a = before.frames.count("") ? before.frames.at("") : a->second;
        const FrontendFrame& clean_b = own.frames.count("") ? own.frames.at("") : b->second;
        warp = warps.emplace(k, MakeTemporalWarp(options_, clean_a, clean_b)).first;
      }
      it = differences
               .emplace(key,
                        WarpedTemporalDifference(warp->second, a->second.gray8, b->second.gray8))
               .first;
    }
    return it->second;
  };
  const auto value = [&](const FrontendMetric& m, const std::string& label) {
    const auto before = previous.find(m.skip);
    if (before == previous.end() || !before->second) return kNan;
    if (m.base == "flicker") {
      return difference_of(m.skip, label, *before->second) -
             difference_of(m.skip, "", *before->second);
    }
    const FrontendPair* pair = pair_of(m.skip, m.detector, label, *before->second);
    return pair ? pair->Get(m.base) : kNan;
  };
  for (const FrontendMetric& m : metrics_) {
    result->reference_metrics[m.name] = value(m, "");
    for (MethodResult& row : result->methods) {
      if (!row.error.empty()) continue;
      row.metrics[m.name] = value(m, row.label);
    }
  }
}

}  // namespace turbid
