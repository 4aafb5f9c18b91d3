// Scene JSON files: being written (see scenes/scene_loader.h for the contract).
#include "scenes/error.h"
#include "scenes/scene_loader.h"

namespace turbid {

Scene LoadSceneFile(const std::string& json_path) {
  throw Error(json_path, "scene files are not supported yet in this build");
}

}  // namespace turbid
