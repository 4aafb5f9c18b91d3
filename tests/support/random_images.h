// Seeded random test inputs for the property tests (issue 17): images of awkward sizes and contents.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <random>
#include <string>

namespace turbid::testing {

// What a random image holds.
enum class ImageContent { kUniformNoise, kConstant, kBlackWhite, kGradient, kNearZero, kNearOne };

struct RandomImage {
  cv::Mat image;  // CV_32FC1 or CV_32FC3, values in [0, 1]
  std::string what;  // "17x1 colour gradient" for messages
};

inline const char* ContentName(ImageContent content) {
  switch (content) {
    case ImageContent::kUniformNoise: return "noise";
    case ImageContent::kConstant: return "constant";
    case ImageContent::kBlackWhite: return "black/white";
    case ImageContent::kGradient: return "gradient";
    case ImageContent::kNearZero: return "near-zero";
    case ImageContent::kNearOne: return "near-one";
  }
  return "?";
}

// A random float image in [0, 1] of the given size and channels.
inline cv::Mat MakeImage(std::mt19937_64& rng, int rows, int cols, int channels,
                         ImageContent content) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  cv::Mat image(rows, cols, CV_32FC(channels));
  const float level = unit(rng);
  for (int y = 0; y < rows; ++y) {
    float* row = image.ptr<float>(y);
    for (int i = 0; i < cols * channels; ++i) {
      const int x = i / channels;
      switch (content) {
        case ImageContent::kUniformNoise: row[i] = unit(rng); break;
        case ImageContent::kConstant: row[i] = level; break;
        case ImageContent::kBlackWhite: row[i] = unit(rng) < 0.5f ? 0.0f : 1.0f; break;
        case ImageContent::kGradient:
          row[i] = static_cast<float>(x + y + i % channels) / static_cast<float>(rows + cols + 1);
          break;
        case ImageContent::kNearZero: row[i] = 1e-6f * unit(rng); break;
        case ImageContent::kNearOne: row[i] = 1.0f - 1e-6f * unit(rng); break;
      }
    }
  }
  return image;
}

// Case `seed`: a size from {1x1, thin lines, odd sizes, up to 61x47}, 1 or 3 channels, any content.
inline RandomImage MakeRandomImage(uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 1);
  static const int kSides[] = {1, 2, 3, 5, 7, 11, 16, 17, 31, 47, 61};
  const auto side = [&] { return kSides[rng() % (sizeof kSides / sizeof kSides[0])]; };
  const int rows = side();
  const int cols = side();
  const int channels = rng() % 2 == 0 ? 1 : 3;
  const auto content = static_cast<ImageContent>(rng() % 6);
  RandomImage out;
  out.image = MakeImage(rng, rows, cols, channels, content);
  out.what = std::to_string(cols) + "x" + std::to_string(rows) + " " +
             (channels == 1 ? "gray " : "colour ") + ContentName(content);
  return out;
}

}  // namespace turbid::testing
