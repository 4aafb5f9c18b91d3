// Atomic writes under a file-size limit (setrlimit RLIMIT_FSIZE in a child process, SIGXFSZ
// ignored as the CLI does): one clear error naming the reason, the destination untouched (absent,
// or its previous bytes), no temporary left. Temporaries of killed writers are recognised and
// removed by the folder's owner; the folder lock is exclusive.
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>

#include "core/error.h"
#include "scenes/image_io.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;
using testing::ReadFileText;
using testing::TempDir;

// Runs `body` in a child process whose files may not grow beyond `limit_bytes`; returns the
// child's exit status (0: every EXPECT in `body` held; the body reports failures on stderr).
int InChildWithFileSizeLimit(rlim_t limit_bytes, const std::function<bool()>& body) {
  std::cout.flush();
  const pid_t child = fork();
  if (child == 0) {
    struct sigaction ignore {};
    ignore.sa_handler = SIG_IGN;
    sigaction(SIGXFSZ, &ignore, nullptr);
    const struct rlimit limit = {limit_bytes, limit_bytes};
    if (setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(3);
    _exit(body() ? 0 : 1);
  }
  int status = 0;
  waitpid(child, &status, 0);
  if (WIFSIGNALED(status)) return 100 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

bool Check(bool ok, const std::string& what) {
  if (!ok) std::cerr << "FAILED in child: " << what << "\n";
  return ok;
}

int Temporaries(const std::string& dir) {
  int n = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    n += IsTemporaryName(entry.path().filename().string());
  return n;
}

// Expects `write` to throw one line naming `path` and "File too large".
bool FailsWithFileTooLarge(const std::string& path, const std::function<void()>& write) {
  try {
    write();
  } catch (const Error& e) {
    const std::string message = e.what();
    return Check(message.rfind(path + ": ", 0) == 0, "message names the file: " + message) &&
           Check(message.find("File too large") != std::string::npos,
                 "message names the reason: " + message) &&
           Check(message.find('\n') == std::string::npos, "one line: " + message);
  }
  return Check(false, path + ": no error past the file-size limit");
}

TEST(AtomicFile, WritesPastAFileSizeLimitFailCleanly) {
  TempDir dir;
  const std::string text = dir.File("out.txt");
  const std::string kept = dir.File("kept.txt");
  std::ofstream(kept) << "previous bytes\n";
  const int status = InChildWithFileSizeLimit(32 * 1024, [&] {
    const std::string big(100 * 1024, 'x');
    bool ok = FailsWithFileTooLarge(text, [&] { AtomicWriteText(text, big, false); });
    ok &= Check(!fs::exists(text), "no file under the final name");
    ok &= FailsWithFileTooLarge(kept, [&] { AtomicWriteText(kept, big, true); });
    ok &= Check(ReadFileText(kept) == "previous bytes\n", "the previous file is kept");
    // Images: PNG (noise does not compress), EXR and PFM encoders.
    cv::Mat noise(128, 128, CV_32FC3);
    cv::randu(noise, 0.0, 1.0);
    WriteImageOptions options;
    options.bit_depth = 16;
    for (const char* name : {"noise.png", "noise.exr", "noise.pfm"}) {
      const std::string path = dir.File(name);
      ok &= FailsWithFileTooLarge(path, [&] { WriteImage(path, noise, options); });
      ok &= Check(!fs::exists(path), std::string(name) + ": no file under the final name");
    }
    ok &= Check(Temporaries(dir.path()) == 0, "no temporary file left");
    // Below the limit, writes work.
    AtomicWriteText(text, "small\n", false);
    ok &= Check(ReadFileText(text) == "small\n", "a small write works");
    return ok;
  });
  EXPECT_EQ(status, 0) << "see the child's messages above (1: a check failed, 1xx: signal)";
}

TEST(AtomicFile, TemporaryNamesAreRecognised) {
  for (const char* name : {".items.csv.tmp1a2b3c4d.csv", ".journal.jsonl.tmpffee0011.jsonl",
                           ".hull-c0001.png.tmp0.png", ".manifest.tmpabc", ".x.tmp12"})
    EXPECT_TRUE(IsTemporaryName(name)) << name;
  for (const char* name : {"items.csv", ".turbid.lock", ".items.csv.tmp.csv", "items.csv.tmp1",
                           ".a.png.tmp12.jpg", ".tmp12", ".x.tmpxyz", ".notes.txt"})
    EXPECT_FALSE(IsTemporaryName(name)) << name;
}

TEST(AtomicFile, StaleTemporariesAreRemovedWhereAskedOnly) {
  TempDir dir;
  fs::create_directories(dir.File("thumbs/a"));
  fs::create_directories(dir.File("report"));
  const auto touch = [&](const std::string& name) { std::ofstream(dir.File(name)) << "x"; };
  for (const char* name :
       {".items.csv.tmp1234.csv", "thumbs/a/.dcp.png.tmpbeef.png", ".report.html.tmp99.html",
        "report/.plot.png.tmp77.png", "items.csv", "thumbs/a/dcp.png"})
    touch(name);
  EXPECT_EQ(RemoveStaleTemporaries(dir.path(), false), 2);  // items.csv's and report.html's
  touch(".items.csv.tmp1234.csv");
  touch(".report.html.tmp99.html");
  EXPECT_EQ(RemoveStaleTemporaries(dir.path(), true, {"report.html", "report"}), 2);
  EXPECT_FALSE(fs::exists(dir.File("thumbs/a/.dcp.png.tmpbeef.png")));
  EXPECT_TRUE(fs::exists(dir.File(".report.html.tmp99.html")));
  EXPECT_TRUE(fs::exists(dir.File("report/.plot.png.tmp77.png")));
  EXPECT_TRUE(fs::exists(dir.File("items.csv")));
  EXPECT_TRUE(fs::exists(dir.File("thumbs/a/dcp.png")));
  EXPECT_EQ(RemoveStaleTemporaries(dir.File("missing"), true), 0);
}

TEST(AtomicFile, TheFolderLockIsExclusive) {
  TempDir dir;
  const std::string folder = dir.File("out");
  {
    const FolderLock lock(folder, "generate");
    EXPECT_TRUE(fs::is_directory(folder));
    try {
      const FolderLock second(folder, "generate");
      ADD_FAILURE() << "a second lock on the same folder";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                folder +
                    ": is being written by another turbid generate; wait for it to finish "
                    "or use another --out");
    }
  }
  EXPECT_NO_THROW(FolderLock(folder, "generate"));  // released with the first
}

}  // namespace
}  // namespace turbid
