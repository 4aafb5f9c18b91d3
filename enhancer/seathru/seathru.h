// The `seathru` enhancement method (Akkaynak & Treibitz, CVPR 2019): blind, needs geometry. Fits
// the water to the image itself (water_fit.h), removes the backscatter and divides the direct
// signal by the fitted illuminant, J_c = D_c e^{β^D_c(r) r} / k_c, then white-balances.
#pragma once

#include <opencv2/core.hpp>

#include "core/fields.h"
#include "enhancer/seathru/water_fit.h"

namespace turbid {

struct SeathruOptions {
  WaterFitOptions fit;
  // Reflectance the illuminant's scale stands for (Sea-thru's f = 2 is 0.5): J = ρ/ρ̄ · this.
  double mean_reflectance = 0.5;
  bool Check(std::string* why) const;
};
const Fields<SeathruOptions>& SeathruFields();

struct SeathruResult {
  cv::Mat image;   // restored J, B, G, R, [0, 1]; pixels without a range keep the input
  cv::Mat direct;  // D = I - B(r)
  WaterFit fit;
};

// image: linear CV_32FC3 (B, G, R); range_m: CV_32FC1 of the same size, NaN / <= 0 = unknown.
SeathruResult Seathru(const SeathruOptions& options, const cv::Mat& image, const cv::Mat& range_m);
// The restoration alone, with a given fit.
cv::Mat SeathruRestore(const WaterFit& fit, double mean_reflectance, const cv::Mat& image,
                       const cv::Mat& range_m, const cv::Mat& direct = cv::Mat());

}  // namespace turbid
