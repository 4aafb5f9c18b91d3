// Writes the seed corpora of fuzz/corpus/ (committed; rerun after a format changes):
//   build-san/fuzz/make_seeds fuzz/corpus
// Every seed is made here, by our writers, OpenCV's encoders (JPEG, TIFF, PGM) and the turbid CLI
// itself (render sidecars, a sweep journal, a generate manifest); none comes from a dataset. The
// NYU .mat seeds are written by make_nyu_seeds.py (h5py).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz/journal_experiment.h"
#include "scenes/image_io.h"
#include "simulator/render.h"
#include "tools/cli/cli.h"

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace turbid;

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void Put(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

void Run(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"turbid"};
  argv.insert(argv.end(), args.begin(), args.end());
  if (RunCli(argv) != 0) throw std::runtime_error("make_seeds: turbid " + args[0] + " failed");
}

cv::Mat Gradient(int w, int h, int channels) {
  cv::Mat m(h, w, channels == 3 ? CV_32FC3 : CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = 0.1f + 0.8f * static_cast<float>(x + y) / static_cast<float>(w + h);
      if (channels == 3)
        m.at<cv::Vec3f>(y, x) = cv::Vec3f(v, 1.0f - v, 0.5f);
      else
        m.at<float>(y, x) = v;
    }
  return m;
}

// NumPy .npy v1.0 of a float32 (or uint16) 2-D array, header padded to 128 bytes.
std::string Npy(const cv::Mat& m, const char* descr) {
  std::string header = std::string("{'descr': '") + descr +
                       "', 'fortran_order': False, 'shape': (" + std::to_string(m.rows) + ", " +
                       std::to_string(m.cols) + "), }";
  header.append(128 - 10 - header.size() - 1, ' ');
  header += '\n';
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  out.append(reinterpret_cast<const char*>(m.data), m.total() * m.elemSize());
  return out;
}

// The image fuzzer's inputs: one selector byte (the extension, image_fuzzer.cc) + the file.
void ImageSeeds(const fs::path& out, const fs::path& tmp) {
  const cv::Mat rgb = Gradient(5, 4, 3), gray = Gradient(5, 4, 1);
  WriteImageOptions o;
  o.overwrite = true;
  WriteImage((tmp / "a.png").string(), rgb, o);
  o.bit_depth = 16;
  WriteImage((tmp / "b.png").string(), gray, o);
  WriteImage((tmp / "c.exr").string(), rgb, o);
  WriteImage((tmp / "d.pfm").string(), gray, o);
  cv::Mat rgb8, gray16;
  rgb.convertTo(rgb8, CV_8U, 255.0);
  gray.convertTo(gray16, CV_16U, 65535.0);
  cv::imwrite((tmp / "e.jpg").string(), rgb8);
  cv::imwrite((tmp / "f.tif").string(), gray16);
  cv::imwrite((tmp / "g.tif").string(), rgb);  // float TIFF
  cv::imwrite((tmp / "h.pgm").string(), gray16);
  cv::imwrite((tmp / "i.ppm").string(), rgb8);
  const std::vector<std::pair<std::string, int>> files = {{"a.png", 0}, {"b.png", 0}, {"e.jpg", 1},
                                                          {"f.tif", 2}, {"g.tif", 2}, {"c.exr", 3},
                                                          {"d.pfm", 4}, {"h.pgm", 5}, {"i.ppm", 5}};
  for (const auto& [name, selector] : files)
    Put(out / "image" / name, std::string(1, static_cast<char>(selector)) + Slurp(tmp / name));
  cv::Mat depth16;
  gray.convertTo(depth16, CV_16U, 5000.0);
  Put(out / "image" / "j.npy", std::string(1, '\6') + Npy(gray, "<f4"));
  Put(out / "image" / "k.npy", std::string(1, '\6') + Npy(depth16, "<u2"));
}

// Scene files naming the scene fuzzer's fixtures (scene_fuzzer.cc), and one naming its blob.
void SceneSeeds(const fs::path& out, const fs::path& tmp) {
  const json camera = {{"fx", 10.0}, {"fy", 10.0}, {"cx", 3.5}, {"cy", 2.5}};
  const std::vector<std::pair<std::string, json>> scenes = {
      {"rgbd",
       {{"type", "rgbd"},
        {"image", "image.png"},
        {"depth", "depth16.png"},
        {"camera", {{"fx", 10.0}, {"fy", -10.0}, {"cx", 3.5}, {"cy", 2.5}}}}},
      {"depth_pfm",
       {{"type", "depth"},
        {"image", "image.png"},
        {"depth", "depth.pfm"},
        {"camera", camera},
        {"plane", {{"normal", {0, 0, -1}}, {"offset_m", 2.0}}}}},
      {"depth_exr",
       {{"type", "depth"},
        {"image", "image.png"},
        {"depth", "depth.exr"},
        {"camera", camera},
        {"color", "linear"},
        {"dvl", {{0.1, 0.2, 1.5}}}}},
      {"stereo",
       {{"type", "stereo"},
        {"image", "image.png"},
        {"disparity", "depth.pfm"},
        {"camera", camera},
        {"baseline_m", 0.1},
        {"doffs_px", 0.5}}},
      {"builtin", {{"type", "builtin"}, {"builtin", "room"}, {"scale", 0.05}}},
      {"folder", {{"type", "folder"}, {"folder", "set"}, {"camera", camera}, {"frames", "0:2"}}},
      {"folder_npy",
       {{"type", "folder"},
        {"folder", "."},
        {"rgb_dir", "set/rgb"},
        {"depth_dir", "set/depth"},
        {"camera", camera},
        {"frames", {"f2"}},
        {"depth_kind", "ray"},
        {"name", "f"}}},
      {"nyu", {{"type", "nyu_v2"}, {"file", "blob.mat"}, {"frames", 0}, {"crop_border", true}}},
  };
  for (const auto& [name, scene] : scenes) Put(out / "scene" / (name + ".json"), scene.dump());
  // With a blob: a 5x4 PNG as "blob.png" (selector 0) for the depth of a depth scene.
  const json blob_scene = {{"type", "depth"},
                           {"image", "image.png"},
                           {"depth", "blob.png"},
                           {"depth_scale", 1000},
                           {"camera", camera}};
  Put(out / "scene" / "blob_png",
      blob_scene.dump() + std::string("\0\0", 2) + Slurp(tmp / "b.png"));
  Put(out / "scene" / "blob_npy",
      json{{"type", "depth"}, {"image", "image.png"}, {"depth", "blob.npy"}, {"camera", camera}}
              .dump() +
          std::string("\0\6", 2) + Npy(Gradient(8, 6, 1), "<f4"));
}

void RenderParamSeeds(const fs::path& out) {
  Put(out / "render_params" / "defaults.json", RenderOptionsToJson(RenderOptions{}).dump());
  Put(out / "render_params" / "sets", std::string("{}\0", 3) +
                                          "light.incidence=paper_eq5\npsf.optical_thickness=2\n"
                                          "water.type=3C\nseed=7\nlight.lights.0.power=4");
  Put(out / "render_params" / "custom_water",
      R"({"water": {"type": "custom", "beta_rgb_per_m": [0.4, 0.2, 0.1]}, "camera": {"bit_depth": 16}})");
  Put(out / "render_params" / "no_light", std::string(R"({"model": "revised"})") +
                                              std::string("\0", 1) +
                                              "light.lights=[]\npsf.enabled=false\nsnow.density_per_m3=0");
}

void SidecarSeeds(const fs::path& out, const fs::path& tmp) {
  const std::vector<std::vector<std::string>> variants = {
      {},
      {"--water", "3C", "--set", "light.incidence=paper_eq5"},
      {"--beta", "0.5", "--set", "snow.enabled=false", "--set", "camera.encoding=linear"},
  };
  fs::create_directories(out / "sidecar");
  int n = 0;
  for (const auto& extra : variants) {
    const std::string image = (tmp / ("render" + std::to_string(n) + ".png")).string();
    std::vector<std::string> args = {"render", "--scene", "seafloor", "--scale", "0.05",
                                     "--seed", "1",       "--out",    image,     "--force"};
    args.insert(args.end(), extra.begin(), extra.end());
    Run(args);
    fs::copy_file(tmp / ("render" + std::to_string(n) + ".json"),
                  out / "sidecar" / ("sidecar" + std::to_string(n) + ".json"),
                  fs::copy_options::overwrite_existing);
    ++n;
  }
}

void ExperimentSeeds(const fs::path& out, const fs::path& repo) {
  fs::create_directories(out / "experiment");
  for (const char* name : {"demo.json", "examples/paper.json"})
    fs::copy_file(repo / "scenes/experiments" / name,
                  out / "experiment" / fs::path(name).filename(),
                  fs::copy_options::overwrite_existing);
  Put(out / "experiment" / "journal.json", turbid::fuzz::kJournalExperiment);
  Put(out / "experiment" / "sampled.json", R"({"name": "s", "scenes": ["room"], "scale": 0.05,
    "grid": {"water.type": ["I", "3C"]},
    "samples": {"count": 3, "seed": 2, "params": {"psf.forward_scatter": {"uniform": [0.5, 1.0]},
      "light.lights.0.power": {"int_uniform": [1, 9]}}},
    "level": "water.type", "methods": ["dcp", {"name": "full", "label": "f", "params": {}},
      {"name": "mine", "results": "mine.csv"}],
    "render": {"psf": {"forward_scatter": 0.8}}, "best_excludes": ["dcp"],
    "metrics": ["ssim", "uiqm"], "ground_truth": "lit"})");
  Put(out / "experiment" / "shard", "2/8\n");
}

void GenerateSeeds(const fs::path& out, const fs::path& repo) {
  fs::create_directories(out / "generate");
  for (const char* name : {"uwcnn.json", "uwcnn_constant_b.json"})
    fs::copy_file(repo / "scenes/experiments/examples" / name, out / "generate" / name,
                  fs::copy_options::overwrite_existing);
  Put(out / "generate" / "grid.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.05, "seed": 4,
    "format": "png", "base": {"camera": {"bit_depth": 8}},
    "grid": {"water.beta_gray_per_m": [0.2, 0.8], "light.lights.0.power": [2, 8]},
    "random": {"count": 2, "seed": 7, "params": {"psf.forward_scatter": {"log_uniform": [0.5, 1.0]},
    "water.type": {"choice": ["I", "II"]}}}})");
}

void JournalAndManifestSeeds(const fs::path& out, const fs::path& tmp) {
  Put(tmp / "exp.json", turbid::fuzz::kJournalExperiment);
  Run({"sweep", (tmp / "exp.json").string(), "--out", (tmp / "sweep").string(), "--quiet",
       "--threads", "1", "--force"});
  const std::string journal = Slurp(tmp / "sweep" / "journal.jsonl");
  Put(out / "journal" / "complete.jsonl", journal);
  Put(out / "journal" / "partial.jsonl", journal.substr(0, journal.size() * 2 / 3));
  Put(tmp / "gen.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.05,
    "grid": {"water.beta_gray_per_m": [0.2, 0.8]}})");
  Run({"generate", (tmp / "gen.json").string(), "--out", (tmp / "gen").string(), "--threads", "1"});
  Put(out / "manifest" / "manifest_csv", std::string(1, '\0') + Slurp(tmp / "gen/manifest.csv"));
  Put(out / "manifest" / "manifest_jsonl",
      std::string(1, '\1') + Slurp(tmp / "gen/manifest.jsonl"));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_seeds OUT_DIR (e.g. fuzz/corpus, from the repository root)\n";
    return 2;
  }
  const fs::path out = argv[1];
  const fs::path repo = fs::absolute(out).parent_path().parent_path();
  const fs::path tmp = fs::temp_directory_path() / "turbid_make_seeds";
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  try {
    ImageSeeds(out, tmp);
    SceneSeeds(out, tmp);
    RenderParamSeeds(out);
    SidecarSeeds(out, tmp);
    ExperimentSeeds(out, repo);
    GenerateSeeds(out, repo);
    JournalAndManifestSeeds(out, tmp);
  } catch (const std::exception& e) {
    std::cerr << "make_seeds: " << e.what() << "\n";
    return 1;
  }
  fs::remove_all(tmp);
  return 0;
}
