// Forward scatter from the water's scattering: psf.model "small_angle" (docs/model.md, "Small-angle
// forward scatter").
//
// Light from a surface point at range r reaches the camera in two parts (small-angle theory:
// W. H. Wells, "Loss of resolution in water as a result of multiple small-angle scattering",
// JOSA 59(6) 686 (1969); B. L. McGlamery, Proc. SPIE 208 (1980); J. S. Jaffe, IEEE J. Ocean.
// Eng. 15(2) 101 (1990), the forward-scatter component):
//   ballistic   e^{-c r} J                                   never scattered: a delta
//   glow        (e^{-(c - b_f) r} - e^{-c r}) J              scattered forwards at least once
// with b_f = b (1 - b_b/b) the forward-scattering coefficient (scattering within 90 degrees keeps
// travelling towards the camera; backscattering and absorption remove light). The glow's
// apparent angle psi (from the camera, relative to the direct line of sight) after one scattering
// by theta at distance s from the camera is theta (1 - s / r) (small angles); with scattering
// events uniform along the path and their angles adding as independent random vectors (the
// second-moment form of the small-angle approximation; derivation in docs/model.md), the mean
// square apparent angle of light scattered n times is n <theta^2> / 3, and of the glow (n >= 1,
// Poisson with mean b_f r)
//   <psi^2>(r) = b_f r <theta^2> / (3 (1 - e^{-b_f r})),
// <theta^2> the mean square angle of the phase function within 90 degrees
// (PhaseFunction::MeanSquareAngle(pi/2)). turbid spreads the glow as the 2-D Gaussian with that
// second moment (per axis variance <psi^2>/2) and converts angle to pixels with the focal length:
// sigma_x = |fx| sqrt(<psi^2>/2), sigma_y = |fy| sqrt(<psi^2>/2) (half the image scale, half the
// pixel width). Each pixel takes the glow of its own range (gather form, like eq. 2's t):
//   [J * h](x) = J(x) + (e^{b_f r(x)} - 1) (G_{sigma(r(x))} * J)(x),
// which the renderer multiplies by t = e^{-c r}: ballistic + glow exactly as above.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "scenes/scene.h"
#include "simulator/psf.h"
#include "simulator/veil.h"

namespace turbid {

// One channel's small-angle constants.
struct SmallAngleChannel {
  double c_per_m = 0.0;                 // beam attenuation c
  double b_per_m = 0.0;                 // scattering coefficient b
  double forward_per_m = 0.0;           // b_f = b (1 - b_b/b)
  double mean_square_angle_rad2 = 0.0;  // <theta^2> of the phase function within 90 degrees
};

// Per channel of `water` (image order). Throws Error for an invalid phase function.
std::vector<SmallAngleChannel> SmallAngleChannels(const VeilWater& water);

// <psi^2>(r) of the glow, rad^2 (2-D: per axis half of it); <theta^2> / 3 as r -> 0.
double GlowMeanSquareAngle(const SmallAngleChannel& channel, double range_m);

// e^{b_f r} - 1, the glow's share relative to the ballistic e^{-c r} (b_f r clamped to 80, where
// e^{-c r} underflows in float anyway; 0 for NaN range).
double GlowFactor(const SmallAngleChannel& channel, double range_m);

// What ApplySmallAnglePsf did, for the sidecar and the tests.
struct SmallAngleReport {
  std::vector<double> sigma_rad;                  // per-axis angular sigma of each level, ascending
  double sigma_min_px = 0.0, sigma_max_px = 0.0;  // over the pixels (x axis)
  bool exact = false;  // one width per channel: every pixel got its own kernel
};

// J + (e^{b_f r} - 1) G_{sigma(r)} * J per pixel and channel (image: float32, 1 or 3 channels as
// water; range_m: CV_32FC1, NaN = open water: J unchanged there, the render's t is 0). Widths are
// `options.glow_levels` levels geometric in sigma between the image's extremes; each pixel's glow
// is linear in sigma^2 between the two levels around it (exact when there is one width).
// Borders mirrored (BORDER_REFLECT_101, repeated for kernels wider than the image).
cv::Mat ApplySmallAnglePsf(const PsfOptions& options, const VeilWater& water,
                           const CameraIntrinsics& camera, const cv::Mat& range_m,
                           const cv::Mat& image, SmallAngleReport* report = nullptr);

// One float32 plane blurred by the normalised sampled Gaussian exp(-(i^2/(2 sx^2) + j^2/(2 sy^2)))
// (sigma 0: a delta along that axis) under BORDER_REFLECT_101 repeated as often as the kernel
// needs (separable: each row, then each column, mirrored by 8 sigma + 2 pixels each side and
// convolved through a DFT of a fast length).
cv::Mat MirroredGaussianBlur(const cv::Mat& plane, double sigma_x_px, double sigma_y_px);

}  // namespace turbid
