#include "simulator/image_pool.h"

#include <deque>
#include <iterator>
#include <mutex>
#include <utility>

namespace turbid::internal {
namespace {

// cv::MatAllocator with OpenCV's StdMatAllocator layout (continuous, fastMalloc alignment) and a
// free list of large buffers keyed by byte size.
class PoolAllocator : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data0, size_t* step,
                         cv::AccessFlag /*flags*/,
                         cv::UMatUsageFlags /*usage_flags*/) const override {
    size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) {
      if (step) {
        if (data0 && step[i] != cv::Mat::AUTO_STEP) {
          CV_Assert(total <= step[i]);
          total = step[i];
        } else {
          step[i] = total;
        }
      }
      total *= sizes[i];
    }
    uchar* data = data0 ? static_cast<uchar*>(data0) : Take(total);
    cv::UMatData* u = new cv::UMatData(this);
    u->data = u->origdata = data;
    u->size = total;
    if (data0) u->flags |= cv::UMatData::USER_ALLOCATED;
    return u;
  }

  bool allocate(cv::UMatData* u, cv::AccessFlag /*flags*/,
                cv::UMatUsageFlags /*usage_flags*/) const override {
    return u != nullptr;
  }

  void deallocate(cv::UMatData* u) const override {
    if (!u) return;
    CV_Assert(u->urefcount == 0 && u->refcount == 0);
    if (!(u->flags & cv::UMatData::USER_ALLOCATED)) {
      Give(u->origdata, u->size);
      u->origdata = nullptr;
    }
    delete u;
  }

 private:
  uchar* Take(size_t bytes) const {
    if (bytes >= kMinPooledBytes) {
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto it = free_.rbegin(); it != free_.rend(); ++it) {  // newest first
        if (it->second != bytes) continue;
        uchar* data = it->first;
        pooled_bytes_ -= bytes;
        free_.erase(std::next(it).base());
        return data;
      }
    }
    return static_cast<uchar*>(cv::fastMalloc(bytes));
  }

  void Give(uchar* data, size_t bytes) const {
    if (bytes < kMinPooledBytes || bytes > kMaxPooledBytes) {
      cv::fastFree(data);
      return;
    }
    std::deque<std::pair<uchar*, size_t>> released;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      free_.emplace_back(data, bytes);  // newest last
      pooled_bytes_ += bytes;
      while (pooled_bytes_ > kMaxPooledBytes) {
        released.push_back(free_.front());
        pooled_bytes_ -= free_.front().second;
        free_.pop_front();
      }
    }
    for (const auto& [block, size] : released) cv::fastFree(block);
  }

  mutable std::mutex mutex_;
  mutable std::deque<std::pair<uchar*, size_t>> free_;
  mutable size_t pooled_bytes_ = 0;
};

}  // namespace

cv::MatAllocator* ImagePool() {
  static PoolAllocator* const pool = new PoolAllocator;  // intentionally never destroyed
  return pool;
}

cv::Mat PooledMat(cv::Size size, int type) {
  cv::Mat m;
  m.allocator = ImagePool();
  m.create(size, type);
  return m;
}

}  // namespace turbid::internal
