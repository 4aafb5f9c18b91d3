// NYU Depth v2 labelled set (Silberman, Hoiem, Kohli & Fergus, "Indoor Segmentation and Support
// Inference from RGBD Images", ECCV 2012): the file nyu_depth_v2_labeled.mat, MATLAB v7.3, i.e.
// HDF5 with a 512-byte user block. Read with the HDF5 C library, one frame at a time (hyperslab).
//
// Axis order. MATLAB holds images as 480x640x3xN (H, W, C, N) and depths as 480x640xN, column-major;
// HDF5 lists dimensions slowest-first, so the file stores images as (N, 3, 640, 480) and depths as
// (N, 640, 480) -- what h5py shows. Element images[n][c][x][y] is row y, column x, channel c (RGB);
// the reader transposes it to an H x W image. Layout and units: docs/formats.md.
#pragma once

#include <opencv2/core.hpp>

#include <string>

#include "scenes/image_io.h"
#include "scenes/scene.h"

namespace turbid {

// Kinect RGB intrinsics published with the NYU Depth v2 toolbox (camera_params.m: fx_rgb, fy_rgb,
// cx_rgb, cy_rgb), for the full 640x480 frame, used as turbid's 0-based pixel-centre coordinates.
CameraIntrinsics NyuKinectRgbCamera();

// The NYU toolbox's conservative valid-projection region (get_projection_mask.m:
// mask(45:471, 41:601), 1-based inclusive): 0-based rows 44..470 and columns 40..600, 561x427.
// Outside it the RGB frame has the white border left by registering depth to colour.
cv::Rect NyuBorderCropBox();

struct NyuFrameOptions {
  // Crop to NyuBorderCropBox(); cx and cy then shift by the box's origin (-40, -44).
  bool crop_border = false;
  // Depth dataset: "depths" (in-painted, dense, metres) or "rawDepths" (projected raw Kinect depth,
  // metres, 0 where unknown).
  std::string depth_dataset = "depths";
  // Encoding of the 8-bit images (the Kinect's colour is sRGB-like; "linear" keeps codes / 255).
  Transfer color = Transfer::kSrgb;
  bool Check(std::string* why) const;
};

// Number of frames N after checking the file's layout: `images` uint8 (N, 3, 640, 480) and the depth
// dataset float32/float64 (N, 640, 480). Throws Error("<path>: <problem>") for a file that is not
// HDF5, a missing dataset, a wrong type or shape.
int NyuFrameCount(const std::string& path, const NyuFrameOptions& options = {});

struct NyuFrame {
  cv::Mat image;    // CV_32FC3 BGR, linear, [0, 1], 480x640 (427x561 cropped)
  cv::Mat depth_m;  // CV_32FC1 z-depth, metres; NaN where the file holds 0
  CameraIntrinsics camera;  // NyuKinectRgbCamera(), shifted when cropped; width/height set
  std::string sha256;       // of the frame's raw bytes as stored (image, then depth)
};

// Reads frame `index` (0-based, as h5py indexes; MATLAB's images(:,:,:,index+1)). Depth: 0 = unknown
// (NaN, the rawDepths convention); negative or non-finite values are an Error naming the frame and
// pixel (the labelled set's depths are finite and non-negative by construction).
NyuFrame ReadNyuFrame(const std::string& path, int index, const NyuFrameOptions& options = {});

}  // namespace turbid
