// One entry point for every scene source: built-in procedural scenes and scene files (JSON) that
// point at dataset frames (TUM / ICL-NUIM RGB-D, stereo disparity, float depth). The harness,
// `turbid render` and `turbid scene` all call LoadScene. Schema and units: docs/formats.md.
#pragma once

#include <string>

#include "scenes/scene.h"

namespace turbid {

struct LoadSceneOptions {
  // Size scale in (0, 1] applied to built-in scenes (file scenes are loaded at their own size).
  double builtin_scale = 1.0;
  bool Check(std::string* why) const;
};

// spec: "builtin:NAME", a bare built-in name ("hull", "seafloor", "room"), or the path of a scene
// JSON file. The result has passed Scene::Validate(). Throws Error("<file>: <problem>").
Scene LoadScene(const std::string& spec, const LoadSceneOptions& options = {});

// True when `spec` names a built-in scene ("builtin:NAME" or a bare known name that is not an
// existing file).
bool IsBuiltinSpec(const std::string& spec);

// Loads a scene JSON file (strict schema: unknown keys and bad values are errors naming the file).
// Relative paths inside the file are resolved against the file's folder. input_hashes records the
// sha256 of the JSON file and of every file it references.
Scene LoadSceneFile(const std::string& json_path);

}  // namespace turbid
