// Procedural images with known haze for the baseline tests (tests/enhancer/baselines_*_test.cc).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <random>

namespace turbid::baselines_test {

// Colour (BGR) texture of 4x4 blocks. In every block one channel is 0 and the others are drawn
// from [0.1, 0.9], so every patch of 4x4 or more has a zero channel: the dark channel prior holds
// exactly. With `zero_in_green_blue_only`, the zero is always G or B and red is drawn from
// [0.5, 0.9]: the underwater (G, B) prior holds, the classic one need not.
inline cv::Mat DarkPriorTexture(int rows, int cols, bool zero_in_green_blue_only,
                                uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(0.1f, 0.9f);
  std::uniform_real_distribution<float> red(0.5f, 0.9f);
  cv::Mat image(rows, cols, CV_32FC3);
  for (int by = 0; by < rows; by += 4) {
    for (int bx = 0; bx < cols; bx += 4) {
      cv::Vec3f colour(value(rng), value(rng), zero_in_green_blue_only ? red(rng) : value(rng));
      const int zero = static_cast<int>(rng() % (zero_in_green_blue_only ? 2 : 3));
      colour[zero] = 0.0f;
      for (int y = by; y < std::min(by + 4, rows); ++y) {
        for (int x = bx; x < std::min(bx + 4, cols); ++x) image.at<cv::Vec3f>(y, x) = colour;
      }
    }
  }
  return image;
}

// Single-scattering haze I = J t + A (1 - t) (He 2011 eq. 1), t one value per pixel.
inline cv::Mat AddHaze(const cv::Mat& clean, const cv::Mat& transmission,
                       const cv::Vec3f& airlight) {
  cv::Mat hazy(clean.size(), clean.type());
  const int channels = clean.channels();
  for (int y = 0; y < clean.rows; ++y) {
    for (int x = 0; x < clean.cols; ++x) {
      const float t = transmission.at<float>(y, x);
      for (int c = 0; c < channels; ++c) {
        hazy.ptr<float>(y)[x * channels + c] =
            clean.ptr<float>(y)[x * channels + c] * t + airlight[c] * (1.0f - t);
      }
    }
  }
  return hazy;
}

// Transmission that is 0 on the first `sky_cols` columns (pure airlight, like a distant
// background) and rises linearly from t_left to t_right over the rest.
inline cv::Mat ColumnTransmission(int rows, int cols, int sky_cols, float t_left, float t_right) {
  cv::Mat t(rows, cols, CV_32FC1);
  for (int x = 0; x < cols; ++x) {
    const float value = x < sky_cols
                            ? 0.0f
                            : t_left + (t_right - t_left) * static_cast<float>(x - sky_cols) /
                                           static_cast<float>(cols - 1 - sky_cols);
    t.col(x).setTo(value);
  }
  return t;
}

// Smooth colourful texture in [0.05, 0.95] without an exact dark channel (for CAP and fusion).
inline cv::Mat SmoothColourTexture(int rows, int cols) {
  cv::Mat image(rows, cols, CV_32FC3);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const float u = static_cast<float>(x) / cols;
      const float v = static_cast<float>(y) / rows;
      image.at<cv::Vec3f>(y, x) =
          cv::Vec3f(0.5f + 0.45f * std::sin(6.283f * (3 * u + 0.2f * v)),
                    0.5f + 0.45f * std::sin(6.283f * (2 * v + 0.7f * u) + 1.0f),
                    0.5f + 0.45f * std::cos(6.283f * (4 * u * v) + 2.0f));
    }
  }
  return image;
}

}  // namespace turbid::baselines_test
