// Camera trajectories over the built-in scenes (docs/formats.md "Sequences"): a lawn-mower survey
// over the scene's dominant plane, a pass along it, or a hover with small motion. Poses are
// camera-to-world in the scene's own world (scenes/builtin.h BuiltinScenePose), one per frame,
// deterministic.
#pragma once

#include <string>
#include <vector>

#include "core/fields.h"
#include "scenes/pose.h"

namespace turbid {

struct TrajectoryOptions {
  // "survey": lanes along the dominant plane's in-plane axis u (the camera's x projected on it),
  // each lane_length_m long, the next lane (1 - overlap) footprints further along v, at constant
  // height above the plane; the orientation stays the scene's own (the vehicle crabs back along
  // the next lane). "pass": one straight line along u. "hover": the scene's own pose plus small
  // sinusoidal motion (three incommensurate frequencies per axis, translation and rotation).
  std::string kind = "survey";
  int frames = 30;              // number of poses, [1, 100000]
  double frame_rate_hz = 10.0;  // (0, 1000]
  double speed_m_per_s = 0.3;   // survey / pass: along the path, [0, 10]
  // survey / pass: distance from the camera to the dominant plane, metres; 0 = the scene's own.
  double altitude_m = 0.0;
  double overlap = 0.6;  // survey: shared fraction of neighbouring lanes' footprints, [0, 0.95]
  double lane_length_m = 3.0;       // survey: (0, 1000]
  double hover_amplitude_m = 0.03;  // hover: translation amplitude per axis, [0, 1]
  double hover_rotation_deg = 1.0;  // hover: rotation amplitude per axis, [0, 10]
  double hover_period_s = 4.0;      // hover: period of the slowest component, (0, 1000]

  bool Check(std::string* why) const;
};

const Fields<TrajectoryOptions>& TrajectoryFields();

// The poses of `options` over built-in scene `scene` (its dominant plane and pose). Throws Error
// for an unknown scene or options failing Check.
std::vector<Pose> BuiltinTrajectory(const std::string& scene, const TrajectoryOptions& options);

}  // namespace turbid
