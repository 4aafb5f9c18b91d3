// Inputs that are not regular files (a FIFO, /dev/zero, a folder) are refused before they are
// opened or read; symbolic links to regular files keep working (core/input_file.h).
#include "core/input_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <functional>
#include <string>

#include "core/error.h"
#include "scenes/image_io.h"
#include "core/json_io.h"
#include "scenes/npy_io.h"
#include "scenes/scene_loader.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& body) {
  try {
    body();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// A FIFO nobody writes to: opening it for reading would block forever.
std::string MakeFifo(const testing::TempDir& dir, const std::string& name) {
  const std::string path = dir.File(name);
  EXPECT_EQ(::mkfifo(path.c_str(), 0600), 0);
  return path;
}

TEST(InputFile, RegularFilesAndLinksToThemPass) {
  testing::TempDir dir;
  const std::string file = dir.Write("a.json", "{}");
  fs::create_symlink(file, dir.File("link.json"));
  EXPECT_EQ(InputFileProblem(file), "");
  EXPECT_EQ(InputFileProblem(dir.File("link.json")), "");
  EXPECT_EQ(ReadJsonFile(dir.File("link.json")), nlohmann::json::object());
}

TEST(InputFile, FifosDevicesAndFoldersAreRefusedBeforeReading) {
  testing::TempDir dir;
  const std::string fifo = MakeFifo(dir, "fifo.png");
  fs::create_symlink(fifo, dir.File("link-to-fifo.json"));
  fs::create_directory(dir.File("folder.json"));
  for (const std::string& path :
       {fifo, dir.File("link-to-fifo.json"), std::string("/dev/zero"), dir.File("folder.json")}) {
    EXPECT_EQ(InputFileProblem(path), "not a regular file") << path;
    EXPECT_EQ(ErrorOf([&] { ReadJsonFile(path); }), path + ": not a regular file");
    EXPECT_EQ(ErrorOf([&] { ReadInputFile(path); }), path + ": not a regular file");
    EXPECT_EQ(ErrorOf([&] { ReadNpy(path); }), path + ": not a regular file");
    EXPECT_FALSE(IsNpyFile(path));
  }
  // The image reader (its folder message stays), format detection and .npy depth maps.
  EXPECT_EQ(ErrorOf([&] { ReadImage(fifo); }), fifo + ": not a regular file");
  EXPECT_EQ(ErrorOf([&] { ReadImage("/dev/zero"); }), "/dev/zero: not a regular file");
  EXPECT_EQ(ErrorOf([&] { DetectImageFormat(fifo); }), fifo + ": not a regular file");
  EXPECT_EQ(InputFileProblem(dir.File("missing")), "file not found");
}

TEST(InputFile, SceneFilesNamingFifosAreRefused) {
  testing::TempDir dir;
  const std::string fifo = MakeFifo(dir, "rgb.png");
  MakeFifo(dir, "depth.npy");
  const std::string scene =
      dir.Write("s.json", R"({"type": "rgbd", "image": "rgb.png", "depth": "depth.npy"})");
  const std::string message = ErrorOf([&] { LoadScene(scene); });
  EXPECT_NE(message.find(": not a regular file"), std::string::npos) << message;
  const std::string fifo_scene = MakeFifo(dir, "fifo-scene.json");
  EXPECT_EQ(ErrorOf([&] { LoadScene(fifo_scene); }), fifo_scene + ": not a regular file");
}

}  // namespace
}  // namespace turbid
