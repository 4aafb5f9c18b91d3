// Every baseline, through its registry entry with default parameters, returns a finite image in
// [0,1] with the input's size and channels on the extreme inputs of issue 5 item 7 and on the
// built-in scenes, gray and colour; bad input throws Error.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/baselines/registry.h"
#include "scenes/builtin.h"
#include "core/error.h"

namespace turbid {
namespace {

struct NamedImage {
  std::string name;
  cv::Mat image;
};

std::vector<NamedImage> ExtremeImages() {
  std::vector<NamedImage> images;
  for (int channels : {1, 3}) {
    const std::string suffix = channels == 1 ? " gray" : " colour";
    const int type = CV_32FC(channels);
    images.push_back({"black" + suffix, cv::Mat(24, 32, type, cv::Scalar::all(0.0))});
    images.push_back({"white" + suffix, cv::Mat(24, 32, type, cv::Scalar::all(1.0))});
    images.push_back({"constant" + suffix, cv::Mat(24, 32, type, cv::Scalar::all(0.37))});
    images.push_back({"1x1" + suffix, cv::Mat(1, 1, type, cv::Scalar::all(0.6))});
    images.push_back({"1x1 black" + suffix, cv::Mat(1, 1, type, cv::Scalar::all(0.0))});
    cv::Mat tiny(3, 3, type, cv::Scalar::all(0.2));
    tiny.at<float>(1, channels) = 0.9f;  // one brighter value
    images.push_back({"3x3" + suffix, tiny});
    cv::Mat line(1, 17, type, cv::Scalar::all(0.3));
    line.colRange(8, 17).setTo(cv::Scalar::all(1.0));
    images.push_back({"1x17 step" + suffix, line});
    // Half black, half saturated.
    cv::Mat half(20, 20, type, cv::Scalar::all(0.0));
    half.colRange(10, 20).setTo(cv::Scalar::all(1.0));
    images.push_back({"half saturated" + suffix, half});
  }
  // Saturated primaries: pure red, pure blue-green.
  images.push_back({"pure red", cv::Mat(16, 16, CV_32FC3, cv::Scalar(0, 0, 1))});
  images.push_back({"pure cyan", cv::Mat(16, 16, CV_32FC3, cv::Scalar(1, 1, 0))});
  cv::Mat stripes(16, 16, CV_32FC3, cv::Scalar(0, 0, 1));
  for (int x = 0; x < 16; x += 2) stripes.col(x).setTo(cv::Scalar(1, 0, 0));
  images.push_back({"saturated stripes", stripes});
  return images;
}

void ExpectValidOutput(const cv::Mat& out, const cv::Mat& in, const std::string& what) {
  ASSERT_EQ(out.size(), in.size()) << what;
  ASSERT_EQ(out.type(), in.type()) << what;
  ASSERT_TRUE(cv::checkRange(out, true)) << what << ": non-finite output";
  double lo, hi;
  cv::minMaxLoc(out.reshape(1), &lo, &hi);
  EXPECT_GE(lo, 0.0) << what;
  EXPECT_LE(hi, 1.0) << what;
}

TEST(BaselinesExtremes, FiniteAndInRangeOnExtremeImages) {
  for (const MethodEntry& entry : BaselineMethodEntries()) {
    for (const NamedImage& named : ExtremeImages()) {
      EnhanceInput input;
      input.image = named.image;
      cv::Mat out;
      ASSERT_NO_THROW(out = entry.run(nlohmann::json::object(), input))
          << entry.info.name << " on " << named.name;
      ExpectValidOutput(out, named.image, entry.info.name + " on " + named.name);
    }
  }
}

TEST(BaselinesExtremes, FiniteAndInRangeOnBuiltinScenes) {
  BuiltinSceneOptions options;
  options.scale = 0.25;
  options.supersampling = 1;
  for (const std::string& name : BuiltinSceneNames()) {
    const Scene scene = MakeBuiltinScene(name, options);
    // Add a blue-green veil so the priors have something to remove.
    cv::Mat hazy = scene.image * 0.6 +
                   (scene.image.channels() == 3 ? cv::Scalar(0.3, 0.25, 0.05) : cv::Scalar(0.3));
    for (const MethodEntry& entry : BaselineMethodEntries()) {
      EnhanceInput input;
      input.image = hazy;
      const cv::Mat out = entry.run(nlohmann::json::object(), input);
      ExpectValidOutput(out, hazy, entry.info.name + " on " + name);
      // Every method changes a hazy image.
      EXPECT_GT(cv::norm(out, hazy, cv::NORM_L1) / hazy.total(), 1e-3) << entry.info.name;
    }
  }
}

TEST(BaselinesExtremes, BadInputThrowsError) {
  cv::Mat nan_image(4, 4, CV_32FC1, cv::Scalar(0.5));
  nan_image.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  const std::vector<cv::Mat> bad = {cv::Mat(), cv::Mat(4, 4, CV_8UC1, cv::Scalar(3)),
                                    cv::Mat(4, 4, CV_32FC2, cv::Scalar::all(0.5)), nan_image};
  for (const MethodEntry& entry : BaselineMethodEntries()) {
    for (const cv::Mat& image : bad) {
      EnhanceInput input;
      input.image = image;
      try {
        entry.run(nlohmann::json::object(), input);
        ADD_FAILURE() << entry.info.name << " accepted a bad image";
      } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind(entry.info.name + ":", 0), 0u) << e.what();
      }
    }
  }
}

}  // namespace
}  // namespace turbid
