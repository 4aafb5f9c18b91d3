// Front-end metrics in sweeps (docs/experiments.md "Sequences"): a sequence's frames are items,
// and a front-end metric of item f (frame f of one scene under one condition) scores the pair
// (f - k, f) for each method row and for the clean frames (the item's reference_metrics, the
// tables' "ground truth" column). Frames f < k have NaN (no pair; left out of n).
//
// The pair needs frame f - k's outputs. Each item publishes a FrameRecord of its frame (per method
// label and the clean frame: the 8-bit luma the camera writes, the features of the detectors the
// metrics ask for, the depth and the pose) in a FrameStore shared by the sweep's threads; item f
// takes frame f - k's record from it, waiting while another thread computes it, or computes it
// itself (render + methods, no scores) when no thread does: the frame is in another shard, was
// journaled by an earlier run, or failed. Either way the record holds the same bytes (renders,
// methods and detectors are deterministic), so the tables do not depend on threads, shards or
// resumption. Records are dropped once every frame that pairs with them has taken them.
#pragma once

#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "metrics/frontend.h"
#include "tools/harness/experiment.h"
#include "tools/harness/score_domain.h"
#include "tools/harness/stage_profile.h"
#include "tools/harness/tables.h"

namespace turbid {

// One frame as the front end sees it through each method ("" = the clean frame).
struct FrameRecord {
  std::map<std::string, FrontendFrame> frames;
};

class SequenceScorer {
 public:
  // The experiment's front-end metrics (HarnessMetricInfo::sequence); items as ExpandItems.
  SequenceScorer(const Experiment& experiment, StageProfile* profile);

  // The record of a frame: `images` by label ("" = clean), each linear [0, 1]; a method that
  // failed is absent. Encoded with `camera`, reduced to luma, features detected.
  std::shared_ptr<const FrameRecord> Build(const Scene& frame, const Pose& pose,
                                           const CameraCoding& camera,
                                           const std::map<std::string, cv::Mat>& images) const;

  // The item says it is computing its record (false: another thread already is or did).
  bool Claim(const ItemSpec& item);
  // Publishes a record claimed with Claim (null: the item failed; waiting threads compute it).
  void Publish(int index, std::shared_ptr<const FrameRecord> record);
  // The record of item `index`, from the store (waiting while it is computed) or from compute().
  std::shared_ptr<const FrameRecord> Take(
      int index, const std::function<std::shared_ptr<const FrameRecord>()>& compute);

  // Fills the front-end metrics of `result` (its rows and reference_metrics) for item `item`
  // whose own record is `own`; `record_of(index)` returns the record of another item (Take).
  void Score(const ItemSpec& item, const FrameRecord& own,
             const std::function<std::shared_ptr<const FrameRecord>(int index)>& record_of,
             ItemResult* result) const;

  const std::vector<FrontendMetric>& metrics() const { return metrics_; }
  const FrontendOptions& options() const { return options_; }

 private:
  struct Entry {
    std::shared_future<std::shared_ptr<const FrameRecord>> future;
    std::shared_ptr<std::promise<std::shared_ptr<const FrameRecord>>> promise;
    int consumers = 0;  // frames of this run still to take it (f + k for each skip k)
  };
  int Consumers(const ItemSpec& spec) const;

  const Experiment& experiment_;
  StageProfile* profile_;
  FrontendOptions options_;
  std::vector<FrontendMetric> metrics_;
  std::vector<int> skips_;  // distinct, ascending
  std::vector<FeatureDetector> detectors_;
  std::map<FeatureDetector, unsigned> parts_;  // FrontendPart bits the detector's metrics need
  std::vector<int> scene_frames_;              // frames of each scene
  std::mutex mutex_;
  std::map<int, Entry> entries_;  // by item index
};

}  // namespace turbid
