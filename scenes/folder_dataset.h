// Generic RGB-D folder datasets: ROOT/rgb/*.png|jpg (colour) beside ROOT/depth/*.png|exr|pfm|npy
// (depth), paired by file stem -- the shape SUN RGB-D-, ScanNet- or Hypersim-style exports take.
// Units, depth kinds and the scene-file keys that drive it: docs/formats.md ("Folder datasets").
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace turbid {

struct FolderDatasetOptions {
  std::string rgb_dir = "rgb";      // colour subfolder (relative to the root, or absolute)
  std::string depth_dir = "depth";  // depth subfolder (relative to the root, or absolute)
  bool Check(std::string* why) const;
};

struct FolderFrame {
  std::string stem;        // shared file stem, e.g. "000012"
  std::string rgb_path;    // .png / .jpg / .jpeg
  std::string depth_path;  // .png / .exr / .pfm / .npy
};

// Every frame, in natural stem order ("f2" before "f10"). Extensions are matched case-insensitively;
// hidden files and other extensions are ignored. Throws Error("<folder>: <problem>") for a missing
// folder, no frames, two files with one stem in a folder, or any stem found on one side only.
std::vector<FolderFrame> ListFolderFrames(const std::string& root,
                                          const FolderDatasetOptions& options = {});

// Natural order: digit runs compare as numbers, everything else bytewise.
bool NaturalLess(const std::string& a, const std::string& b);

// A depth file's values as stored (not scaled): .npy by our reader, every other format by ReadImage
// with keep_raw. `integer` tells whether the file holds integer codes (PNG, PGM/PPM, JPEG, uint16 .npy; TIFF counts as float), so that
// callers can insist on an explicit scale for them.
struct RawDepthFile {
  cv::Mat values;  // CV_32FC1 (or more channels, which callers reject)
  bool integer = false;
};
RawDepthFile ReadRawDepthFile(const std::string& path);

}  // namespace turbid
