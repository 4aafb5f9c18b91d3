// Procedural built-in scenes: ray-cast planes, boxes and spheres with textures rich enough for
// feature matching, exact depth, normals and plane equation. No external files. Contract used by
// every module's tests; extend, do not break.
#pragma once

#include <string>
#include <vector>

#include "scenes/scene.h"

namespace turbid {

struct BuiltinSceneOptions {
  // Output size scale in (0, 1]: 1 gives the scene's native size (hull 1360x1024, seafloor and room
  // 640x480); smaller values shrink the image and scale the intrinsics for fast tests.
  double scale = 1.0;
  bool Check(std::string* why) const;
};

// "hull" (oblique ship-hull plate, gray), "seafloor" (seafloor with rocks, color),
// "room" (ICL-NUIM-like box room, color).
std::vector<std::string> BuiltinSceneNames();
// Throws Error for an unknown name. Deterministic: same name and options give the same bytes.
Scene MakeBuiltinScene(const std::string& name, const BuiltinSceneOptions& options = {});

}  // namespace turbid
