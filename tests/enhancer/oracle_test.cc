// The oracles (enhancer/oracle/oracle.h): oracle_exact reaches float precision on noise-free float
// renders (one PSF and the range-dependent one); the oracle-parameter LMMSE reference beats the
// input and the blind methods on noisy 8-bit renders (PSNR and SSIM at least those of the input,
// simplified and clahe); masked open water is counted and does not ring into its neighbours.
#include "enhancer/oracle/oracle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "enhancer/blocks/box_filter.h"
#include "enhancer/oracle/oracle_internal.h"
#include "enhancer/registry.h"
#include "metrics/full_reference.h"
#include "metrics/ssim.h"
#include "scenes/builtin.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "tests/enhancer/oracle_reference.h"

namespace turbid {
namespace {

double MaxAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  double hi = 0;
  cv::minMaxLoc(d.reshape(1), nullptr, &hi);
  return hi;
}

double PsnrOf(const cv::Mat& reference, const cv::Mat& image) {
  return Psnr(PsnrOptions{}, reference, image);
}
double SsimOf(const cv::Mat& reference, const cv::Mat& image) {
  return Ssim(SsimOptions{}, reference, image).mean;
}

Scene Builtin(const std::string& name, double scale) {
  BuiltinSceneOptions so;
  so.scale = scale;
  return MakeBuiltinScene(name, so);
}

// Float images equal bit for bit, except that any NaN equals any NaN (which NaN an addition of
// two NaNs gives depends on its operand order, which a compiler may swap).
bool SameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type() || a.depth() != CV_32F) return false;
  for (int y = 0; y < a.rows; ++y) {
    const float* p = a.ptr<float>(y);
    const float* q = b.ptr<float>(y);
    for (int i = 0; i < a.cols * a.channels(); ++i) {
      if (std::isnan(p[i]) && std::isnan(q[i])) continue;
      if (std::memcmp(&p[i], &q[i], sizeof(float)) != 0) return false;
    }
  }
  return true;
}

// The oracle's box sums give cv::boxFilter's values bit for bit (the same double operations in
// the same order): windows 3 and 5 (direct sums) and larger ones (running sums), sums and means,
// one and three channels, odd and tiny sizes (windows wider than the image), and values many
// orders of magnitude apart, where any other summation order gives other values (a running sum
// that passed a 1e30 keeps its rounding error): uniform values, signed values 1e-30 .. 1e30 with
// zeros and negative zeros, and some infinities and NaNs.
TEST(Oracle, BoxFilterReflectEqualsOpenCvBitForBit) {
  uint64_t seed = 11;
  int compared = 0;
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(2, 3), cv::Size(7, 1), cv::Size(1, 9), cv::Size(5, 40),
        cv::Size(37, 21), cv::Size(130, 97), cv::Size(272, 205)}) {
    for (int ch : {1, 3}) {
      for (int kind = 0; kind < 3; ++kind) {
        cv::RNG rng(seed++);
        cv::Mat src(size, CV_32FC(ch));
        src.forEach<float>([&](float& v, const int*) { v = 0; });
        for (int y = 0; y < src.rows; ++y) {
          float* p = src.ptr<float>(y);
          for (int i = 0; i < src.cols * ch; ++i) {
            if (kind == 0) {
              p[i] = rng.uniform(0.0f, 1.0f);
            } else {
              const double u = rng.uniform(0.0, 1.0);
              const double mag = std::pow(10.0, rng.uniform(-30.0, 30.0));
              p[i] = u < 0.1 ? 0.0f : u < 0.15 ? -0.0f : static_cast<float>(u < 0.55 ? -mag : mag);
              if (kind == 2 && u > 0.998) {
                p[i] = u > 0.999 ? std::numeric_limits<float>::quiet_NaN()
                                 : std::numeric_limits<float>::infinity();
              }
            }
          }
        }
        for (int radius : {1, 2, 3, 4, 9, 16, 40}) {
          for (bool normalize : {false, true}) {
            const cv::Size window(2 * radius + 1, 2 * radius + 1);
            cv::Mat expected, got;
            cv::boxFilter(src, expected, -1, window, cv::Point(-1, -1), normalize,
                          cv::BORDER_REFLECT);
            BoxFilterReflect(src, got, radius, normalize);
            EXPECT_TRUE(SameBits(got, expected))
                << size << " ch " << ch << " kind " << kind << " radius " << radius
                << (normalize ? " mean" : " sum") << ": max |diff| " << MaxAbsDiff(got, expected);
            ++compared;
          }
        }
        // In place (dst = src).
        cv::Mat expected, in_place = src.clone();
        cv::boxFilter(src, expected, -1, cv::Size(9, 9), cv::Point(-1, -1), false,
                      cv::BORDER_REFLECT);
        BoxFilterReflect(in_place, in_place, 4, false);
        EXPECT_TRUE(SameBits(in_place, expected)) << size << " in place";
      }
    }
  }
  EXPECT_EQ(compared, 8 * 2 * 3 * 7 * 2);
}

// The oracle's fused last step gives the values of the OpenCV calls it replaced (prior + detail,
// the prior copied back onto masked pixels, .mul(irradiance), patchNaNs, min(1), max(0)) bit for
// bit: gray and colour, odd sizes (OpenCV's max keeps -0 in its scalar tail and makes it +0 in its
// vector loop), with NaNs, infinities, values above 1, negative values, and -0 and tiny negative
// products (which round to -0) scattered and at the end of the image.
TEST(Oracle, FinishImageEqualsOpenCvSteps) {
  uint64_t seed = 11;
  int compared = 0;
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(3, 2), cv::Size(37, 21), cv::Size(130, 97), cv::Size(1360, 4)}) {
    for (int ch : {1, 3}) {
      const int type = CV_32FC(ch);
      cv::RNG rng(seed++);
      cv::Mat prior(size, type), detail(size, type), e(size, type), masked(size, CV_8UC1);
      rng.fill(prior, cv::RNG::UNIFORM, -0.5, 1.5);
      rng.fill(detail, cv::RNG::UNIFORM, -0.5, 0.5);
      rng.fill(e, cv::RNG::UNIFORM, 0.1, 2.0);
      rng.fill(masked, cv::RNG::UNIFORM, 0, 2);
      masked *= 255;
      const float specials[] = {-0.0f,
                                0.0f,
                                std::numeric_limits<float>::quiet_NaN(),
                                std::numeric_limits<float>::infinity(),
                                -std::numeric_limits<float>::infinity(),
                                -1e-44f,
                                2.0f};
      const int n = size.area() * ch;
      float* p = prior.ptr<float>();
      float* d = detail.ptr<float>();
      for (int i = 0; i < n; ++i) {
        if (rng.uniform(0, 4) == 0) p[i] = specials[rng.uniform(0, 7)];
        if (rng.uniform(0, 4) == 0) d[i] = i % 2 == 0 ? -0.0f : -p[i];
      }
      p[n - 1] = -0.0f;  // in cv::max's scalar tail (odd sizes)
      d[n - 1] = -0.0f;
      for (bool deblur : {false, true}) {
        for (bool lit : {false, true}) {
          cv::Mat expected = deblur ? cv::Mat(prior + detail) : prior.clone();
          if (deblur) prior.copyTo(expected, masked);
          if (lit) expected = expected.mul(e);
          cv::patchNaNs(expected, 0.0);
          cv::min(expected, 1.0, expected);
          cv::max(expected, 0.0, expected);
          cv::Mat got;
          oracle_internal::FinishImage(prior, deblur ? detail : cv::Mat(), masked,
                                       lit ? e : cv::Mat(), got);
          EXPECT_TRUE(SameBits(got, expected))
              << size << " ch " << ch << " deblur " << deblur << " lit " << lit;
          ++compared;
        }
      }
    }
  }
  EXPECT_EQ(compared, 5 * 2 * 4);
}

// Today's fused data term and MMSE give the pre-optimisation values bit for bit (the same float
// operations in the same order): gray and colour, odd and tiny sizes, masked pixels (t below the
// floor), t E at and below the data term's floor 1e-12 (NaN box sums in the signal variances with
// variant 3's windows), an image value of -1e30 (NaN sums everywhere), clipped samples (censored),
// sensor noise on and off, random images and noisy 8-bit renders of the built-in scenes (with
// random truth maps: the step is arithmetic on the maps); radii giving running and direct row sums
// at each level.
TEST(Oracle, MmseEqualsPreOptimisationImplementation) {
  auto check = [](const std::string& what, const OracleOptions& o, const cv::Mat& image,
                  const cv::Mat& t, const cv::Mat& e, const cv::Mat& snow, const cv::Mat& veil,
                  double gain, double floor_var, double clip) {
    const auto a = oracle_internal::OracleMmse(o, image, t, e, snow, veil, gain, floor_var, clip);
    const auto b = oracle_reference::OracleMmse(o, image, t, e, snow, veil, gain, floor_var, clip);
    EXPECT_EQ(a.masked_pixels, b.masked_pixels) << what;
    EXPECT_EQ(a.censored_pixels, b.censored_pixels) << what;
    EXPECT_EQ(MaxAbsDiff(a.masked, b.masked), 0.0) << what;
    EXPECT_TRUE(SameBits(a.estimate, b.estimate)) << what;
    EXPECT_TRUE(SameBits(a.prior, b.prior)) << what;
    EXPECT_TRUE(SameBits(a.posterior, b.posterior)) << what;
  };
  uint64_t seed = 3;
  std::vector<cv::Mat> renders;
  for (const char* name : {"hull", "seafloor"}) {
    RenderOptions ro;
    ro.seed = 5;
    renders.push_back(Render(ro, Builtin(name, 0.2)).image);
  }
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(3, 2), cv::Size(37, 21), cv::Size(130, 97),
                              renders[0].size(), renders[1].size()}) {
    for (int ch : {1, 3}) {
      const int type = CV_32FC(ch);
      cv::Mat image(size, type), t(size, type), e(size, type), snow(size, type), veil(size, type);
      cv::RNG rng(seed++);
      rng.fill(image, cv::RNG::UNIFORM, 0.0, 1.0);
      for (const cv::Mat& r : renders) {
        if (r.size() == size && r.channels() == ch) r.copyTo(image);
      }
      rng.fill(t, cv::RNG::UNIFORM, 0.0, 1.0);
      rng.fill(e, cv::RNG::UNIFORM, 0.2, 3.0);
      rng.fill(snow, cv::RNG::UNIFORM, 0.0, 0.02);
      rng.fill(veil, cv::RNG::UNIFORM, 0.0, 0.3);
      // Some clipped samples and some pixels below the transmission floor.
      image.forEach<float>([](float& v, const int*) { v = v > 0.9f ? 1.0f : v; });
      t.forEach<float>([](float& v, const int*) { v = v < 0.03f ? 1e-5f : v; });
      // Values at and beside 0.7f, the threshold of variant 3 (0.7f < 0.7: a threshold compared
      // in double instead of float, as cv::compare takes it, masks other pixels).
      t.forEach<float>([](float& v, const int* pos) {
        const int k = (pos[0] * 7 + pos[1]) % 11;
        if (k == 0) v = 0.7f;
        if (k == 1) v = std::nextafter(0.7f, 0.0f);
        if (k == 2) v = std::nextafter(0.7f, 1.0f);
      });
      // Irradiances that put t E at, beside and below the data term's floor 1e-12 where t is not
      // masked (max(t E, 1e-12) is a select on bit masks in the vectorised data term). With
      // variant 3's windows (some middle windows with no data: a box count of [w > 0]) the middle
      // level's signal variance meets NaN box sums there: its mean reaches ~1e21 where a window's
      // sum of a is a negative rounding residue, so w (m - p)^2 overflows and the running sums
      // give inf - inf. The reference's cv::max(v, 0) turns those NaNs into 0 in its vector loop
      // and keeps them in its scalar loop (the last values of its blocks: the image's last value
      // in gray, two of every 258 in colour); from ffe737c to d4dca5d std::max kept them all,
      // and the NaNs spread to almost every value.
      cv::Mat t_floor = t.clone(), e_floor = e.clone();
      for (int y = 0; y < size.height; ++y) {
        for (int i = 0; i < size.width * ch; ++i) {
          float& tv = t_floor.ptr<float>(y)[i];
          float& ev = e_floor.ptr<float>(y)[i];
          const int k = (y * 5 + i * 3) % 13;
          if (k == 4) ev = 1e-14f;
          if (k == 5) ev = 4e-13f;
          if (k == 6) ev = 9e-13f;
          if (k == 7) ev = 1.5e-12f;
          if (k == 8) tv = 1.0f, ev = 1e-12f;
          if (k == 9) tv = 1.0f, ev = std::nextafter(1e-12f, 0.0f);
        }
      }
      // One value of -1e30 in an image with no clipped samples and t above every variant's mask
      // (every value has data: the signal variances' sums of a full window): u = -inf there, so
      // every box sum downstream is NaN and the signal variances take cv::max's NaN handling at
      // every value, the scalar loop's included, in the path with data everywhere too.
      cv::Mat image_inf = image.clone(), t_inf = t.clone();
      for (int y = 0; y < size.height; ++y) {
        for (int i = 0; i < size.width * ch; ++i) {
          float& iv = image_inf.ptr<float>(y)[i];
          float& tv = t_inf.ptr<float>(y)[i];
          iv = std::min(iv, 0.85f);
          tv = std::max(tv, 0.75f);
        }
      }
      image_inf.ptr<float>(size.height / 2)[size.width * ch / 3] = -1e30f;
      for (int variant = 0; variant < 5; ++variant) {
        OracleOptions o;
        if (variant == 1) o.coarse_radius = 9, o.middle_radius = 3, o.pixel_radius = 1;
        // Middle windows of 3 and 5 (direct row sums beside the coarse running sums).
        if (variant == 3) {
          o.coarse_radius = 5, o.middle_radius = 1, o.pixel_radius = 2;
          o.mask_transmission = 0.7;
        }
        if (variant == 4) o.coarse_radius = 40, o.middle_radius = 2, o.pixel_radius = 3;
        const double gain = variant == 2 ? 0.0 : 1.0 / 2000.0;
        const double floor_var = variant == 2 ? 1e-12 : 0.01 * 0.01 + 1.0 / (255.0 * 255.0 * 12);
        const double clip = variant == 2 ? 1.0 - 1e-7 : 1.0 - 0.5 / 255.0 - 1e-7;
        check(std::to_string(size.width) + "x" + std::to_string(size.height) + " ch " +
                  std::to_string(ch) + " variant " + std::to_string(variant),
              o, image, t, e, snow, veil, gain, floor_var, clip);
        check(std::to_string(size.width) + "x" + std::to_string(size.height) + " ch " +
                  std::to_string(ch) + " variant " + std::to_string(variant) + " t E floor",
              o, image, t_floor, e_floor, snow, veil, gain, floor_var, clip);
        check(std::to_string(size.width) + "x" + std::to_string(size.height) + " ch " +
                  std::to_string(ch) + " variant " + std::to_string(variant) + " -1e30",
              o, image_inf, t_inf, e, snow, veil, gain, floor_var, clip);
      }
    }
  }
}

// End to end: today's oracle and oracle_exact give the pre-optimisation values on renders of the
// built-in scenes, gray and colour: 8-bit noisy (the default), float without noise or
// backscatter, a bright LED that clips (censored samples), two lights with normals from the depth,
// and no lights without attenuation; targets clean and lit. Bit for bit
// except the Wiener noise-to-signal ratio: its three masked means are now summed in double in one
// pass (not cv::mean / cv::meanStdDev's order), so it agrees to double rounding (relative 1e-12
// allows ~1e4 ulps); a ratio that far apart moves the deblurred image by less than 1e-12
// relative, i.e. not at all in float (the images are compared bit for bit, and are equal).
TEST(Oracle, EqualsPreOptimisationOracleOnRenders) {
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene builtin = Builtin(name, 0.2);
    for (int variant = 0; variant < 5; ++variant) {
      Scene scene = builtin;
      RenderOptions o;
      o.seed = 3 + variant;
      if (variant == 3) {
        // Two lights, normals from the depth (the truth maps' per-row light geometry).
        LightOptions second;
        second.position_in_camera_m = {0.3, -0.2, 0.1};
        second.half_power_angle_deg = 30.0;
        second.color_rgb = {1.0, 0.8, 0.6};
        o.light.lights.push_back(second);
        scene.normals.release();
      }
      if (variant == 4) {
        // No lights and no attenuation (t = 1 where the depth is valid).
        o.light.lights.clear();
        o.water.beta_rgb_per_m = {0.0, 0.0, 0.0};
        o.water.beta_gray_per_m = 0.0;
      }
      if (variant == 1) {
        o.water.backscatter = false;
        o.camera.bit_depth = 32;
        o.sensor.enabled = false;
      }
      if (variant == 2) {
        o.water.type = "3C";
        o.camera.encoding = CameraEncoding::kLinear;
        o.light.lights[0].power = 20.0;
      }
      const RenderResult r = Render(o, scene);
      for (const char* target : {"clean", "lit"}) {
        const std::string what =
            std::string(name) + " variant " + std::to_string(variant) + " " + target;
        OracleOptions mmse;
        mmse.target = target;
        const OracleResult a = OracleEnhance(mmse, r.image, scene, r.sidecar);
        const OracleResult b = oracle_reference::OracleEnhance(mmse, r.image, scene, r.sidecar);
        EXPECT_TRUE(SameBits(a.image, b.image)) << what;
        EXPECT_EQ(a.masked_pixels, b.masked_pixels) << what;
        EXPECT_NEAR(a.deblur_nsr, b.deblur_nsr, 1e-12 * std::abs(b.deblur_nsr)) << what;
        EXPECT_EQ(a.steps, b.steps) << what;
        OracleExactOptions exact;
        exact.target = target;
        const OracleResult c = OracleExactEnhance(exact, r.image, scene, r.sidecar);
        const OracleResult d =
            oracle_reference::OracleExactEnhance(exact, r.image, scene, r.sidecar);
        EXPECT_TRUE(SameBits(c.image, d.image)) << what << " exact";
        EXPECT_EQ(c.steps, d.steps) << what << " exact";
      }
    }
  }
}

TEST(Oracle, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(OracleOptions{}.Check(&why)) << why;
  EXPECT_TRUE(OracleExactOptions{}.Check(&why)) << why;
  OracleOptions bad;
  bad.middle_radius = bad.coarse_radius;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(Oracle, BothEntriesArePrivilegedAndSayWhatTheyRead) {
  for (const char* name : {"oracle", "oracle_exact"}) {
    const MethodInfo& info = FindMethod(name);
    EXPECT_TRUE(info.privileged) << name;
    EXPECT_TRUE(IsPrivileged(name, nlohmann::json::object())) << name;
    EXPECT_NE(info.inputs.find("sensor noise"), std::string::npos) << name;
    EXPECT_TRUE(info.needs_sidecar && info.needs_geometry) << name;
  }
}

TEST(Oracle, NeedsSceneAndSidecar) {
  cv::Mat img(8, 8, CV_32F, cv::Scalar(0.5));
  EXPECT_THROW(Enhance("oracle", {}, EnhanceInput{img, nullptr, nullptr}), Error);
  EXPECT_THROW(Enhance("oracle_exact", {}, EnhanceInput{img, nullptr, nullptr}), Error);
  EXPECT_THROW(Enhance("oracle", {{"coarse_radius", 1}}, EnhanceInput{img, nullptr, nullptr}),
               Error);
}

// The even-extension inverse undoes the reflect-101 blur the renderer applies, for the Gaussian
// (separable) kernel and a 2-D generalized-Gaussian one.
TEST(Oracle, DeconvolveReflect101InvertsApplyPsf) {
  cv::Mat img(37, 52, CV_32FC3);
  cv::randu(img, 0.0, 1.0);
  for (double thickness : {4.0, 2.0}) {
    PsfOptions o;
    o.optical_thickness = thickness;
    const Psf psf = PsfKernel(o);
    ASSERT_FALSE(psf.is_delta);
    const cv::Mat blurred = ApplyPsf(psf, img);
    EXPECT_GT(MaxAbsDiff(blurred, img), 0.05);
    const cv::Mat back = DeconvolveReflect101(blurred, psf.kernel, 0.0);
    EXPECT_LE(MaxAbsDiff(back, img), 1e-5) << "T = " << thickness;
  }
}

// Noise-free float renders: beta and the light keep t (E_A + E_L) away from 0 and I below the
// clipping point, so every step of the inverse is well conditioned and the error is float
// rounding. Snow stays on (re-rendered from the seed and subtracted).
RenderOptions NoiseFreeFloat(bool depth_dependent_psf, bool turbidity_psf = false) {
  RenderOptions o;
  o.psf.turbidity_dependent = turbidity_psf;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  o.water.beta_rgb_per_m = {0.5, 0.4, 0.3};
  o.water.beta_gray_per_m = 0.4;
  o.water.backscatter = true;
  o.psf.depth_dependent = depth_dependent_psf;
  o.light.lights[0].power = 2.0;  // keeps I below 1 (the default 8 saturates near the LED)
  return o;
}

TEST(Oracle, ExactInverseReachesFloatPrecisionOnNoiseFreeFloatRenders) {
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = Builtin(name, 0.125);
    double max_range = 0;
    cv::minMaxLoc(Renderer(scene).range_m(), nullptr, &max_range);
    for (int mode : {0, 1, 2}) {
      // 0: one PSF; 1: range-dependent width; 2: turbidity-dependent (T = beta r per pixel).
      const bool depth_dependent = mode == 1;
      RenderOptions options = NoiseFreeFloat(depth_dependent, mode == 2);
      // Widths sigma sqrt(r / r_max) <= sigma: wider kernels make the blur numerically singular
      // (the float rounding of the render, divided by the kernel's smallest frequency response,
      // exceeds 1e-5).
      options.psf.reference_range_m = max_range;
      const RenderResult r = Render(options, scene);
      double hi = 0;
      cv::minMaxLoc(r.image.reshape(1), nullptr, &hi);
      ASSERT_LT(hi, 1.0) << name << ": the render clips; the test needs an unclipped one";
      const OracleResult out = OracleExactEnhance(OracleExactOptions{}, r.image, scene, r.sidecar);
      EXPECT_EQ(out.masked_pixels, 0) << name;
      EXPECT_LE(MaxAbsDiff(out.image, scene.image), 1e-5)
          << name
          << (mode == 2 ? " turbidity-dependent PSF"
                        : (depth_dependent ? " range-dependent PSF" : " one PSF"))
          << ", " << out.iterations << " iterations, residual " << out.residual;
      if (mode > 0) {
        EXPECT_GT(out.iterations, 1) << name;
      }
      // The lit target returns J (unclipped here).
      OracleExactOptions lit;
      lit.target = "lit";
      EXPECT_LE(MaxAbsDiff(OracleExactEnhance(lit, r.image, scene, r.sidecar).image, r.lit), 1e-5)
          << name;
    }
  }
}

// The other models and the single-scatter veil: the oracles take the truth maps from the
// simulator itself, so oracle_exact inverts a noise-free float render of each to float precision
// (no PSF: the test is of the maps, not of the deblurring), and the LMMSE reference on an 8-bit
// render with noise beats its input. uwcnn's encoded domain is refused by name.
TEST(Oracle, InvertsRevisedUwcnnAndSingleScatterRenders) {
  struct Case {
    const char* what;
    ImageModel model;
    VeilModel veil;
  };
  for (const Case& c :
       {Case{"revised", ImageModel::kRevised, VeilModel::kPaper},
        Case{"paper + single_scatter", ImageModel::kPaper, VeilModel::kSingleScatter},
        Case{"revised + single_scatter", ImageModel::kRevised, VeilModel::kSingleScatter},
        Case{"uwcnn linear", ImageModel::kUwcnn, VeilModel::kPaper},
        Case{"ambient derived", ImageModel::kPaper, VeilModel::kPaper},
        Case{"world snow", ImageModel::kPaper, VeilModel::kPaper}}) {
    for (const char* name : {"seafloor", "hull"}) {
      const Scene scene = Builtin(name, 0.125);
      RenderOptions o = NoiseFreeFloat(false, false);
      o.psf.enabled = false;
      o.model = c.model;
      o.veil = c.veil;
      o.uwcnn.domain = UwcnnDomain::kLinear;
      o.uwcnn.type = "II";
      if (std::string(c.what) == "ambient derived") o.ambient = AmbientModel::kDerived;
      if (std::string(c.what) == "world snow") {
        o.snow.mode = "world";
        o.light.lights[0].power = 1.0;  // world particles near the lamp would clip at 2
      }
      const RenderResult r = Render(o, scene);
      double hi = 0;
      cv::minMaxLoc(r.image.reshape(1), nullptr, &hi);
      ASSERT_LT(hi, 1.0) << c.what << " " << name;
      const OracleResult out = OracleExactEnhance(OracleExactOptions{}, r.image, scene, r.sidecar);
      EXPECT_LE(MaxAbsDiff(out.image, scene.image), 2e-5) << c.what << " " << name;
      // Inverting it as eq. 2 with eq. 2's veil (what the oracle did before) is far off.
      RenderRecord as_paper = r.sidecar;
      as_paper.options->model = ImageModel::kPaper;
      as_paper.options->veil = VeilModel::kPaper;
      as_paper.options->ambient = AmbientModel::kTyped;
      as_paper.options->snow.mode = "per_frame";
      EXPECT_GT(MaxAbsDiff(OracleExactEnhance(OracleExactOptions{}, r.image, scene, as_paper).image,
                           scene.image),
                0.02)
          << c.what << " " << name;

      RenderOptions noisy = o;
      noisy.sensor.enabled = true;
      noisy.camera.bit_depth = 8;
      const RenderResult n = Render(noisy, scene);
      const cv::Mat restored = OracleEnhance(OracleOptions{}, n.image, scene, n.sidecar).image;
      EXPECT_GT(PsnrOf(scene.image, restored), PsnrOf(scene.image, n.image) + 3.0)
          << c.what << " " << name;
    }
  }
  const Scene scene = Builtin("seafloor", 0.125);
  RenderOptions small_angle = NoiseFreeFloat(false, false);
  small_angle.psf.model = PsfModel::kSmallAngle;
  const RenderResult s = Render(small_angle, scene);
  EXPECT_THROW(OracleExactEnhance(OracleExactOptions{}, s.image, scene, s.sidecar), Error);
  RenderOptions o = NoiseFreeFloat(false, false);
  o.model = ImageModel::kUwcnn;  // domain "encoded" by default
  const RenderResult r = Render(o, scene);
  try {
    OracleExactEnhance(OracleExactOptions{}, r.image, scene, r.sidecar);
    ADD_FAILURE() << "uwcnn encoded was inverted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("encoded"), std::string::npos) << e.what();
  }
}

// The oracle-parameter LMMSE reference: on noisy 8-bit renders with every default degradation
// (snow, Poisson-Gaussian noise, PSF), the oracle's PSNR and SSIM are at least those of the input
// and of the blind methods simplified and clahe, and far above oracle_exact's where t is small.
TEST(Oracle, BeatsInputAndBlindMethodsOnNoisy8BitRenders) {
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = Builtin(name, 0.25);
    for (double beta : {0.7, 1.5}) {
      RenderOptions o;
      o.water.beta_rgb_per_m = {beta, beta, beta};
      o.water.beta_gray_per_m = beta;
      o.seed = 7;
      const RenderResult r = Render(o, scene);
      EnhanceInput in{r.image, &scene, &r.sidecar};
      const cv::Mat oracle = Enhance("oracle", nlohmann::json::object(), in);
      const double psnr = PsnrOf(scene.image, oracle), ssim = SsimOf(scene.image, oracle);
      EXPECT_GE(psnr, PsnrOf(scene.image, r.image)) << name << " beta " << beta << ": input";
      EXPECT_GE(ssim, SsimOf(scene.image, r.image)) << name << " beta " << beta << ": input";
      for (const char* blind : {"simplified", "clahe"}) {
        const cv::Mat out = Enhance(blind, nlohmann::json::object(), in);
        EXPECT_GE(psnr, PsnrOf(scene.image, out)) << name << " beta " << beta << ": " << blind;
        EXPECT_GE(ssim, SsimOf(scene.image, out)) << name << " beta " << beta << ": " << blind;
      }
      const cv::Mat exact = Enhance("oracle_exact", nlohmann::json::object(), in);
      EXPECT_GT(psnr, PsnrOf(scene.image, exact)) << name << " beta " << beta;
    }
  }
}

// Open water (NaN depth) is masked: counted, filled with the prior mean, finite, and the pixels
// next to it are recovered about as well as the rest (no ringing from the masked values).
TEST(Oracle, MasksOpenWaterWithoutRinging) {
  Scene scene = Builtin("seafloor", 0.25);
  const cv::Rect hole(30, 20, 25, 18);
  scene.depth_m(hole).setTo(std::numeric_limits<float>::quiet_NaN());
  scene.normals.release();
  RenderOptions o;
  o.seed = 3;
  const RenderResult r = Render(o, scene);
  const OracleResult out = OracleEnhance(OracleOptions{}, r.image, scene, r.sidecar);
  EXPECT_EQ(out.masked_pixels, hole.area());
  ASSERT_TRUE(cv::checkRange(out.image));
  bool reported = false;
  for (const std::string& s : out.steps) reported = reported || s.rfind("masked: ", 0) == 0;
  EXPECT_TRUE(reported);
  cv::Mat hole_mask(scene.image.size(), CV_8U, cv::Scalar(0));
  hole_mask(hole).setTo(255);
  cv::Mat near;
  cv::dilate(hole_mask, near, cv::Mat::ones(7, 7, CV_8U));
  near &= ~hole_mask;  // a 3-pixel ring around the hole
  cv::Mat rest = ~near & ~hole_mask;
  cv::Mat err = out.image - scene.image;
  err = err.mul(err);
  const double ring = std::sqrt(cv::mean(err, near)[0]);
  const double elsewhere = std::sqrt(cv::mean(err, rest)[0]);
  EXPECT_LE(ring, 1.5 * elsewhere + 0.01) << "ring " << ring << " elsewhere " << elsewhere;
}

}  // namespace
}  // namespace turbid
