#include "core/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <system_error>

#include "core/error.h"
#include "core/input_file.h"

namespace turbid {
namespace fs = std::filesystem;

namespace {

std::string TemporaryNameFor(const fs::path& path) {
  std::random_device device;
  std::ostringstream name;
  name << path.filename().string() << ".tmp" << std::hex << device() << device();
  // Keep the destination's extension last: encoders pick the format from it.
  name << path.extension().string();
  return (path.parent_path() / ("." + name.str())).string();
}

// The temporary files being written now, readable from a signal handler: fixed slots (no
// allocation), each claimed with an atomic flag. More concurrent writes than slots simply go
// unregistered (their temporaries would stay on a signal, as without the handler).
constexpr int kSlots = 64;
constexpr size_t kPathBytes = 4096;
struct TempSlot {
  std::atomic<bool> claimed{false};
  std::atomic<bool> ready{false};  // path complete: the handler may read it
  char path[kPathBytes];
};
std::array<TempSlot, kSlots> temp_slots;

class RegisteredTemp {
 public:
  explicit RegisteredTemp(const std::string& path) {
    if (path.size() >= kPathBytes) return;
    for (int i = 0; i < kSlots; ++i) {
      bool expected = false;
      if (!temp_slots[i].claimed.compare_exchange_strong(expected, true)) continue;
      std::memcpy(temp_slots[i].path, path.c_str(), path.size() + 1);
      temp_slots[i].ready.store(true);
      slot_ = i;
      return;
    }
  }
  ~RegisteredTemp() {
    if (slot_ < 0) return;
    temp_slots[slot_].ready.store(false);
    temp_slots[slot_].claimed.store(false);
  }
  RegisteredTemp(const RegisteredTemp&) = delete;
  RegisteredTemp& operator=(const RegisteredTemp&) = delete;

 private:
  int slot_ = -1;
};

extern "C" void RemoveTemporariesAndDie(int signal_number) {
  // Only async-signal-safe calls: unlink, sigaction, raise.
  for (TempSlot& slot : temp_slots) {
    if (slot.ready.load()) ::unlink(slot.path);
  }
  struct sigaction restore {};
  restore.sa_handler = SIG_DFL;
  sigemptyset(&restore.sa_mask);
  ::sigaction(signal_number, &restore, nullptr);
  ::raise(signal_number);
}

}  // namespace

void RemoveTemporaryFilesOnSignal() {
  struct sigaction action {};
  action.sa_handler = RemoveTemporariesAndDie;
  sigemptyset(&action.sa_mask);
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(signal_number, &action, nullptr);
  // Past a file-size limit the kernel sends SIGXFSZ, whose default action kills the process
  // mid-write; ignored, the write() fails with EFBIG and the error reaches the user as one line.
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  ::sigaction(SIGXFSZ, &ignore, nullptr);
}

namespace {

// Creates `file` (the temporary of `path`) and writes `bytes` with checked write() calls, then
// fsync() and close(), both checked: a write error the kernel reports late (an I/O error on
// write-back, a quota or a network file system that allocates on flush) fails the write instead of
// leaving a short or empty file under the final name. Errors are OutputError naming `path`.
void WriteFileBytes(const std::string& path, const std::string& file, const std::string& bytes) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw OutputError(path, std::string("cannot create: ") + std::strerror(errno));
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      // n == 0 cannot make progress either; report it as the disk being full.
      const int err = n < 0 ? errno : ENOSPC;
      ::close(fd);
      throw OutputError(path, std::string("cannot write: ") + std::strerror(err) + " (after " +
                                  std::to_string(written) + " of " + std::to_string(bytes.size()) +
                                  " bytes; nothing was written under this name)");
    }
    written += static_cast<size_t>(n);
  }
  if (FsyncOutputs() && ::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {
    const int err = errno;  // EINVAL/EROFS: a file that cannot be synced (nothing to report)
    ::close(fd);
    throw OutputError(path, std::string("cannot write: ") + std::strerror(err) +
                                " (on fsync; nothing was written under this name)");
  }
  // close() reports delayed write errors on some file systems (NFS): checked too.
  if (::close(fd) != 0)
    throw OutputError(path, std::string("cannot write: ") + std::strerror(errno) +
                                " (on close; nothing was written under this name)");
}

// The destination's file name of a temporary file name, "" when `name` is not one: "." + NAME +
// ".tmp" + hex digits [+ EXT, where NAME ends with EXT] (TemporaryNameFor).
std::string TemporaryTarget(const std::string& name) {
  if (name.size() < 6 || name[0] != '.') return "";
  size_t at = name.rfind(".tmp");
  while (at != std::string::npos && at > 1) {
    size_t end = at + 4;
    while (end < name.size() && std::isxdigit(static_cast<unsigned char>(name[end]))) ++end;
    if (end > at + 4) {
      const std::string stem = name.substr(1, at - 1);
      const std::string ext = name.substr(end);
      if (ext.empty()) return stem;
      if (ext[0] == '.' && ext.find('.', 1) == std::string::npos && stem.size() > ext.size() &&
          stem.compare(stem.size() - ext.size(), ext.size(), ext) == 0)
        return stem;
    }
    at = name.rfind(".tmp", at - 1);
  }
  return "";
}

}  // namespace

bool FsyncOutputs() {
  static const bool flush = [] {
    const char* value = std::getenv("TURBID_FSYNC");
    return value == nullptr || std::string(value) != "0";
  }();
  return flush;
}

bool IsTemporaryName(const std::string& name) { return !TemporaryTarget(name).empty(); }

int RemoveStaleTemporaries(const std::string& folder, bool recursive,
                           const std::vector<std::string>& skip) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return 0;
  const fs::path root(folder);
  const auto skipped = [&](const fs::path& entry) {
    const std::string relative = entry.lexically_relative(root).generic_string();
    for (const std::string& name : skip)
      if (relative == name) return true;
    return false;
  };
  int removed = 0;
  // Errors on single entries (a file gone meanwhile, no permission) skip that entry only.
  const auto visit = [&](const fs::directory_entry& entry) {
    std::error_code entry_ec;
    // A regular file itself, not a link (a link is not a temporary turbid wrote).
    if (entry.symlink_status(entry_ec).type() != fs::file_type::regular) return;
    const std::string target = TemporaryTarget(entry.path().filename().string());
    // A temporary of a skipped file is skipped too: its writer may be alive.
    if (target.empty() || skipped(entry.path().parent_path() / target)) return;
    if (fs::remove(entry.path(), entry_ec)) ++removed;
  };
  if (recursive) {
    fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
    for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
      std::error_code entry_ec;
      if (it->is_directory(entry_ec) && skipped(it->path())) {
        it.disable_recursion_pending();
        continue;
      }
      visit(*it);
    }
  } else {
    for (const fs::directory_entry& entry : fs::directory_iterator(root, ec)) visit(entry);
  }
  return removed;
}

FolderLock::FolderLock(const std::string& folder, const std::string& what) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw OutputError(folder, "cannot create the output folder: " + ec.message());
  const std::string path = folder + "/.turbid.lock";
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw OutputError(path, std::string("cannot open the lock file: ") + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd_);
    if (err == EWOULDBLOCK) {
      throw Error(folder, "is being written by another turbid " + what +
                              "; wait for it to finish or use another --out");
    }
    throw Error(path, std::string("cannot lock: ") + std::strerror(err));
  }
}

FolderLock::~FolderLock() { ::close(fd_); }  // closing releases the lock

void AtomicWrite(const std::string& path, bool overwrite,
                 const std::function<void(const std::string& temp_path)>& write) {
  const fs::path target(path);
  std::error_code ec;
  if (!overwrite && fs::exists(target, ec)) {
    throw Error(path, "already exists (use --force to overwrite)");
  }
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec)) {
    throw OutputError(path, "folder " + parent.string() + " does not exist");
  }
  const std::string temp = TemporaryNameFor(target);
  const RegisteredTemp registered(temp);
  try {
    write(temp);
  } catch (...) {
    fs::remove(temp, ec);
    throw;
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw OutputError(path, "cannot rename temporary file into place: " + ec.message());
  }
}

void AtomicWriteText(const std::string& path, const std::string& bytes, bool overwrite) {
  AtomicWrite(path, overwrite, [&](const std::string& temp) { WriteFileBytes(path, temp, bytes); });
}

// FIPS 180-4 SHA-256.
namespace {

class Sha256 {
 public:
  void Update(const unsigned char* data, size_t size) {
    for (size_t i = 0; i < size; ++i) {
      block_[block_size_++] = data[i];
      if (block_size_ == 64) {
        Compress();
        block_size_ = 0;
      }
    }
    total_bytes_ += size;
  }

  std::string HexDigest() {
    const uint64_t total_bits = total_bytes_ * 8;
    const unsigned char one = 0x80;
    Update(&one, 1);
    const unsigned char zero = 0;
    while (block_size_ != 56) Update(&zero, 1);
    for (int i = 7; i >= 0; --i) {
      const unsigned char byte = static_cast<unsigned char>(total_bits >> (8 * i));
      Update(&byte, 1);
    }
    std::ostringstream hex;
    for (uint32_t word : state_) hex << std::hex << std::setw(8) << std::setfill('0') << word;
    return hex.str();
  }

 private:
  static uint32_t Rotr(uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

  void Compress() {
    static constexpr std::array<uint32_t, 64> kRound = {
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
        0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
        0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
        0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
        0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
        0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
        0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
        0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
        0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
        0xc67178f2};
    std::array<uint32_t, 64> w{};
    for (int i = 0; i < 16; ++i) {
      w[i] = (uint32_t(block_[4 * i]) << 24) | (uint32_t(block_[4 * i + 1]) << 16) |
             (uint32_t(block_[4 * i + 2]) << 8) | uint32_t(block_[4 * i + 3]);
    }
    for (int i = 16; i < 64; ++i) {
      const uint32_t s0 = Rotr(w[i - 15], 7) ^ Rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
      const uint32_t s1 = Rotr(w[i - 2], 17) ^ Rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
      w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    std::array<uint32_t, 8> v = state_;
    for (int i = 0; i < 64; ++i) {
      const uint32_t s1 = Rotr(v[4], 6) ^ Rotr(v[4], 11) ^ Rotr(v[4], 25);
      const uint32_t choose = (v[4] & v[5]) ^ (~v[4] & v[6]);
      const uint32_t t1 = v[7] + s1 + choose + kRound[i] + w[i];
      const uint32_t s0 = Rotr(v[0], 2) ^ Rotr(v[0], 13) ^ Rotr(v[0], 22);
      const uint32_t majority = (v[0] & v[1]) ^ (v[0] & v[2]) ^ (v[1] & v[2]);
      const uint32_t t2 = s0 + majority;
      v = {t1 + t2, v[0], v[1], v[2], v[3] + t1, v[4], v[5], v[6]};
    }
    for (int i = 0; i < 8; ++i) state_[i] += v[i];
  }

  std::array<uint32_t, 8> state_ = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                    0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  std::array<unsigned char, 64> block_{};
  size_t block_size_ = 0;
  uint64_t total_bytes_ = 0;
};

}  // namespace

std::string Sha256Bytes(const std::string& bytes) {
  Sha256 hash;
  hash.Update(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  return hash.HexDigest();
}

std::string Sha256File(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open for reading");
  Sha256 hash;
  std::array<char, 1 << 16> buffer{};
  while (in) {
    in.read(buffer.data(), buffer.size());
    hash.Update(reinterpret_cast<const unsigned char*>(buffer.data()),
                static_cast<size_t>(in.gcount()));
  }
  return hash.HexDigest();
}

}  // namespace turbid
