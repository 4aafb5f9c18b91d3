#include "scenes/trajectory.h"

#include <cmath>

#include "core/error.h"
#include "scenes/builtin.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool Within(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// The plane frame of a built-in scene in world coordinates: unit normal n (towards the camera),
// in-plane axes u (the camera's x projected on the plane) and v = n x u, and the camera's distance
// to the plane.
struct PlaneFrame {
  cv::Vec3d n, u, v;
  double distance_m = 0;
};

PlaneFrame DominantPlaneFrame(const std::string& scene, const Pose& pose) {
  BuiltinSceneOptions tiny;
  tiny.scale = 0.05;
  tiny.supersampling = 1;
  const Scene s = MakeBuiltinScene(scene, tiny);
  if (!s.dominant_plane) throw Error("trajectory: builtin scene '" + scene + "' has no plane");
  PlaneFrame f;
  f.n = pose.rotation * s.dominant_plane->normal;
  const cv::Vec3d x = pose.rotation * cv::Vec3d(1, 0, 0);
  f.u = x - f.n * f.n.dot(x);
  f.u /= cv::norm(f.u);
  f.v = f.n.cross(f.u);
  f.distance_m = s.dominant_plane->offset_m;
  return f;
}

// Rotation by |w| radians about w (Rodrigues' formula).
cv::Matx33d AxisAngle(const cv::Vec3d& w) {
  const double angle = cv::norm(w);
  if (angle < 1e-15) return cv::Matx33d::eye();
  const cv::Vec3d k = w / angle;
  const cv::Matx33d kx(0, -k[2], k[1], k[2], 0, -k[0], -k[1], k[0], 0);
  return cv::Matx33d::eye() + std::sin(angle) * kx + (1 - std::cos(angle)) * (kx * kx);
}

// The point at arc length s of a lawn-mower path: lanes of length L along u, joined by steps of
// `spacing` along v, alternating direction.
cv::Vec2d LawnMower(double s, double length, double spacing) {
  const double period = length + spacing;
  const double lane = std::floor(s / period);  // a double: extreme options overflow any int
  const double within = std::max(0.0, s - lane * period);
  const double along = std::min(within, length);
  const double across = lane * spacing + std::max(0.0, within - length);
  return {std::fmod(lane, 2.0) == 0 ? along : length - along, across};
}

}  // namespace

bool TrajectoryOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (kind != "survey" && kind != "pass" && kind != "hover")
    return fail("kind: expected one of survey, pass, hover");
  if (frames < 1 || frames > 100000) return fail("frames: expected an integer in [1, 100000]");
  if (!Within(frame_rate_hz, 1e-9, 1000)) return fail("frame_rate_hz: expected (0, 1000]");
  if (!Within(speed_m_per_s, 0, 10)) return fail("speed_m_per_s: expected [0, 10]");
  if (!Within(altitude_m, 0, 100))
    return fail("altitude_m: expected [0, 100] (0: the scene's own)");
  if (!Within(overlap, 0, 0.95)) return fail("overlap: expected [0, 0.95]");
  if (!Within(lane_length_m, 1e-9, 1000)) return fail("lane_length_m: expected (0, 1000]");
  if (!Within(hover_amplitude_m, 0, 1)) return fail("hover_amplitude_m: expected [0, 1]");
  if (!Within(hover_rotation_deg, 0, 10)) return fail("hover_rotation_deg: expected [0, 10]");
  if (!Within(hover_period_s, 1e-9, 1000)) return fail("hover_period_s: expected (0, 1000]");
  return true;
}

const Fields<TrajectoryOptions>& TrajectoryFields() {
  using O = TrajectoryOptions;
  static const Fields<O> fields =
      Fields<O>()
          .String("kind", &O::kind, "survey, pass or hover")
          .Integer("frames", &O::frames, "number of frames", 1, 100000)
          .Number("frame_rate_hz", &O::frame_rate_hz, "frames per second",
                  NumberRange::AboveUpTo(0, 1000))
          .Number("speed_m_per_s", &O::speed_m_per_s, "survey / pass: speed along the path",
                  NumberRange::Between(0, 10))
          .Number("altitude_m", &O::altitude_m,
                  "survey / pass: distance to the dominant plane, 0 = the scene's own",
                  NumberRange::Between(0, 100))
          .Number("overlap", &O::overlap, "survey: shared fraction of neighbouring lanes",
                  NumberRange::Between(0, 0.95))
          .Number("lane_length_m", &O::lane_length_m, "survey: lane length",
                  NumberRange::AboveUpTo(0, 1000))
          .Number("hover_amplitude_m", &O::hover_amplitude_m, "hover: translation amplitude",
                  NumberRange::Between(0, 1))
          .Number("hover_rotation_deg", &O::hover_rotation_deg, "hover: rotation amplitude",
                  NumberRange::Between(0, 10))
          .Number("hover_period_s", &O::hover_period_s, "hover: slowest period",
                  NumberRange::AboveUpTo(0, 1000));
  return fields;
}

std::vector<Pose> BuiltinTrajectory(const std::string& scene, const TrajectoryOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("trajectory: " + why);
  const Pose home = BuiltinScenePose(scene);
  std::vector<Pose> poses;
  poses.reserve(options.frames);
  if (options.kind == "hover") {
    const double amp_rad = options.hover_rotation_deg * kPi / 180;
    // Periods T, T/1.618, T/2.618 per axis (incommensurate: the motion never repeats exactly).
    const double w = 2 * kPi / options.hover_period_s;
    for (int i = 0; i < options.frames; ++i) {
      const double t = i / options.frame_rate_hz;
      const cv::Vec3d d(std::sin(w * t), std::sin(1.618 * w * t + 1.0),
                        std::sin(2.618 * w * t + 2.0));
      const cv::Vec3d a(std::sin(1.3 * w * t + 0.5), std::sin(2.1 * w * t + 1.5),
                        std::sin(0.7 * w * t + 2.5));
      const cv::Matx33d r = AxisAngle(a * amp_rad);
      poses.push_back({home.rotation * r, home.position_m + options.hover_amplitude_m * d});
    }
    return poses;
  }
  const PlaneFrame f = DominantPlaneFrame(scene, home);
  const double altitude = options.altitude_m > 0 ? options.altitude_m : f.distance_m;
  // The camera moves along the plane at `altitude`: start = home shifted along n.
  const cv::Vec3d start = home.position_m + f.n * (altitude - f.distance_m);
  // Footprint across lanes: the image's extent along v at that distance, from the field of view.
  const CameraIntrinsics cam = BuiltinSceneCamera(scene);
  const double footprint = altitude * cam.height / std::abs(cam.fy);
  const double spacing = footprint * (1.0 - options.overlap);
  const double step = options.speed_m_per_s / options.frame_rate_hz;
  for (int i = 0; i < options.frames; ++i) {
    const double s = i * step;
    const cv::Vec2d p =
        options.kind == "pass" ? cv::Vec2d(s, 0) : LawnMower(s, options.lane_length_m, spacing);
    poses.push_back({home.rotation, start + f.u * p[0] + f.v * p[1]});
  }
  return poses;
}

}  // namespace turbid
