#include "tools/bench/bench_cases.h"

#include <cstdio>
#include <vector>

#include "scenes/builtin.h"
#include "simulator/render.h"

namespace turbid::bench {

Inputs::Inputs(double s) : scale(s) {
  BuiltinSceneOptions so;
  so.scale = s;
  hull_gray = MakeBuiltinScene("hull", so);
  hull_color = hull_gray;
  cv::merge(std::vector<cv::Mat>{hull_gray.image * 0.8, hull_gray.image * 0.95, hull_gray.image},
            hull_color.image);
  hull_color.name = "hull_color";
  seafloor = MakeBuiltinScene("seafloor", so);
  RenderOptions o;
  o.water.type = "3C";
  o.seed = 1;
  o.camera.encoding = CameraEncoding::kLinear;  // the peers read these values as 8-bit codes
  const cv::Mat gray = Render(o, hull_gray).image;
  const cv::Mat color = Render(o, hull_color).image;
  degraded_gray_linear = gray;
  degraded_color_linear = color;
  gray.convertTo(degraded_gray8, CV_8U, 255.0);
  color.convertTo(degraded_color8, CV_8U, 255.0);
  hull_gray.image.convertTo(clean_gray8, CV_8U, 255.0);
  hull_color.image.convertTo(clean_color8, CV_8U, 255.0);
  clean_gray8.convertTo(clean_gray_f, CV_32F, 1.0 / 255.0);
  degraded_gray8.convertTo(degraded_gray_f, CV_32F, 1.0 / 255.0);
  seafloor_degraded_linear = Render(o, seafloor).image;
  seafloor.image.convertTo(seafloor_clean8, CV_8U, 255.0);
  seafloor_degraded_linear.convertTo(seafloor_degraded8, CV_8U, 255.0);
}

std::string Format(const char* format, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, value);
  return buf;
}

double InteriorMaxDiff(const cv::Mat& a, const cv::Mat& b, int border) {
  const cv::Rect inner(border, border, a.cols - 2 * border, a.rows - 2 * border);
  if (inner.width <= 0 || inner.height <= 0) return cv::norm(a, b, cv::NORM_INF);
  return cv::norm(a(inner), b(inner), cv::NORM_INF);
}

}  // namespace turbid::bench
