// Baselines dcp and udcp, with their published defaults:
//   dcp    — He, Sun, Tang, "Single image haze removal using dark channel prior", CVPR 2009 /
//            TPAMI 33(12) 2011, eqs. 5, 11-12, 22, with the guided-filter refinement of He, Sun,
//            Tang, "Guided image filtering", TPAMI 35(6) 2013, §4.4 (r 60, ε 1e-4);
//   udcp   — Drews, do Nascimento, Moraes, Botelho, Campos, "Transmission estimation in underwater
//            single images", ICCV Workshops 2013: the dark channel over G and B only.
// The other baselines: enhancer/baselines/{cap,clahe,fusion,tarel}.h; their registry entries:
// enhancer/baselines/registry.h.
// Every function takes float32 images in [0,1] with 1 or 3 channels (BGR order, linear) and returns
// the same size and channel count, finite and clamped to [0,1]. Empty input, another depth or
// channel count, or non-finite values throw Error; options are checked with Check and throw Error
// naming the parameter. Formulas, defaults and the behaviour on gray input:
// docs/methods-baselines.md.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid {

// Building blocks shared by the prior-based methods (exposed for tests).

// Dark channel (He 2011 eq. 5): per pixel the minimum over the selected channels, then the minimum
// over a patch_size x patch_size square (border: replicate). `skip_red` drops channel 2 (red in
// BGR) as UDCP does; gray images use their one channel either way.
cv::Mat DarkChannel(const cv::Mat& image, int patch_size, bool skip_red = false);

// Airlight (He 2011 §4.4): among the `fraction` brightest pixels of `prior` (at least one), the
// input pixel with the largest channel sum (ties: first in row-major order). Returns the pixel
// position; `airlight` gets the input value there (gray: all three entries equal).
cv::Point EstimateAirlight(const cv::Mat& image, const cv::Mat& prior, double fraction,
                           cv::Vec3f* airlight);

struct DcpOptions {
  // Side of the square dark-channel window, pixels, odd, >= 1. He 2011 §5: 15 x 15.
  int patch_size = 15;
  // Fraction of the haze removed, (0, 1]; keeps a little haze for depth perception. He 2011 eq. 12.
  double omega = 0.95;
  // Lower bound on the transmission when recovering the radiance, (0, 1]. He 2011 eq. 22.
  double t0 = 0.1;
  // Fraction of the brightest dark-channel pixels searched for the airlight, (0, 1]. He 2011 §4.4.
  double airlight_fraction = 0.001;
  // Refine the patch-wise transmission with a guided filter (guide: the input image). He 2013
  // §4.4 replaces the soft matting of He 2011 §4.2 with it.
  bool refine = true;
  // Guided-filter radius, pixels, >= 1 (He 2013 dehazing example: r 60).
  int guided_radius = 60;
  // Guided-filter regulariser ε on [0,1] data, > 0 (He 2013 dehazing example: 1e-4).
  double guided_eps = 1e-4;
  bool Check(std::string* why) const;
};

// UDCP keeps DCP's pipeline and defaults; only the dark channel changes (G and B only).
struct UdcpOptions : DcpOptions {};

struct DcpResult {
  cv::Mat image;             // recovered radiance J, same size and channels as the input, [0,1]
  cv::Mat dark_channel;      // CV_32FC1 dark channel of the input (udcp: of G and B)
  cv::Mat raw_transmission;  // CV_32FC1 patch-wise transmission, He 2011 eq. 12
  cv::Mat transmission;      // CV_32FC1 refined transmission (== raw when refine is off), [0,1]
  cv::Vec3f airlight;        // A per channel, BGR (gray: three equal entries)
  cv::Point airlight_pixel;  // where A was read
};

DcpResult DarkChannelPriorDetailed(const DcpOptions& options, const cv::Mat& image);
cv::Mat DarkChannelPrior(const DcpOptions& options, const cv::Mat& image);
DcpResult UnderwaterDarkChannelPriorDetailed(const UdcpOptions& options, const cv::Mat& image);
cv::Mat UnderwaterDarkChannelPrior(const UdcpOptions& options, const cv::Mat& image);

}  // namespace turbid
