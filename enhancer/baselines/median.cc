// Exact median filter on float images (tarel's two sv x sv medians, Tarel & Hautière 2009 §4.3),
// by comparator networks shared between neighbouring windows, after the idea of separable sorting
// networks (Adams, "Fast median filters using separable sorting networks", SIGGRAPH 2021); the
// networks and their layout here are our own:
//
//  - Output rows go in pairs: the windows of rows y and y+1 share k-1 input rows (the "core"); each
//    adds one private row.
//  - The core's columns are sorted once per pair (k-1 values per column), then merged into sorted
//    blocks of 2, 4, ... columns, each block kept for every x so that the windows of neighbouring
//    pixels reuse it.
//  - For each x, one network merges the blocks that make up k columns, keeping only the k+1 ranks
//    of the core that can still be the window's median whatever the private row holds.
//  - A last network per output row sorts the private row's k values and picks the median of them
//    and that band.
//
// Every step is a min or max of two floats, so the result is one of the window's values: exactly
// the median, whatever the data (ties included; inputs are finite). For k = 11 that is ~340
// comparators per pixel instead of a selection among 121 values. The networks are built by one
// constexpr builder: for Tarel's default k = 11 at compile time, so that each network becomes
// straight-line vector code (values stay in registers between comparators); for any other k at run
// time, executed by a small interpreter.
#include "enhancer/baselines/median.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "enhancer/baselines/common.h"
#include "enhancer/simd_switch.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#define TURBID_MEDIAN_AVX2 1
#endif

namespace turbid {
namespace baselines_internal {
namespace {

// ---------------------------------------------------------------------------------------------
// Building networks

// A vector with a fixed capacity, usable in constant expressions.
template <class T, int N>
struct FixedVec {
  T items[N]{};
  int count = 0;
  constexpr void push_back(const T& v) {
    if (count >= N) throw "FixedVec capacity exceeded";  // a compile error in constant evaluation
    items[count++] = v;
  }
  constexpr int size() const { return count; }
  constexpr bool empty() const { return count == 0; }
  constexpr T& operator[](int i) { return items[i]; }
  constexpr const T& operator[](int i) const { return items[i]; }
  constexpr const T& back() const { return items[count - 1]; }
  constexpr void pop_back() { --count; }
};

template <class T>
struct DynVec : std::vector<T> {
  int size() const { return static_cast<int>(std::vector<T>::size()); }
  T& operator[](int i) { return std::vector<T>::operator[](static_cast<size_t>(i)); }
  const T& operator[](int i) const { return std::vector<T>::operator[](static_cast<size_t>(i)); }
};

struct Comparator {
  int a, b, lo, hi;
};

// One kept comparator on slots: slot lo = min(slot a, slot b), slot hi = max(...). An output that
// nothing reads goes to the last slot, the sink (storing it costs less than a branch).
struct Op {
  int32_t a, b, lo, hi;
};

// Builds comparator networks on symbolic wires (inputs are wires 0..n-1; every comparator makes
// two new wires), then keeps what the wanted outputs depend on and assigns slots. `List` holds
// wires, `Store` comparators; fixed-size ones in constant evaluation, std::vector at run time.
template <class List, class Store>
class NetworkBuilder {
 public:
  constexpr explicit NetworkBuilder(int inputs) : inputs_(inputs), next_wire_(inputs) {}

  static constexpr List Range(int first, int count) {
    List v{};
    for (int i = 0; i < count; ++i) v.push_back(first + i);
    return v;
  }

  // Batcher's odd-even merge for any lengths: once the even-indexed and odd-indexed parts of a
  // and b are merged, at most the pairs (O_i, E_{i+1}) are out of order (0-1 principle).
  constexpr List Merge(const List& a, const List& b) {
    if (a.empty()) return b;
    if (b.empty()) return a;
    List out{};
    if (a.size() == 1 && b.size() == 1) {
      int x = a[0], y = b[0];
      Compare(x, y);
      out.push_back(x);
      out.push_back(y);
      return out;
    }
    const List even = Merge(Stride(a, 0), Stride(b, 0));
    const List odd = Merge(Stride(a, 1), Stride(b, 1));
    out.push_back(even[0]);
    int i = 0;
    for (; i < odd.size(); ++i) {
      if (i + 1 < even.size()) {
        int o = odd[i], e = even[i + 1];
        Compare(o, e);
        out.push_back(o);
        out.push_back(e);
      } else {
        out.push_back(odd[i]);
      }
    }
    for (int j = i + 1; j < even.size(); ++j) out.push_back(even[j]);
    return out;
  }

  constexpr List Sort(const List& wires) {
    if (wires.size() <= 1) return wires;
    const int half = wires.size() / 2;
    List left{}, right{};
    for (int i = 0; i < wires.size(); ++i) (i < half ? left : right).push_back(wires[i]);
    return Merge(Sort(left), Sort(right));
  }

  int wires() const { return next_wire_; }
  const Store& comparators() const { return comparators_; }

  // The comparators the wanted wires depend on, in build order, as ops on slots: inputs keep
  // slots 0..inputs-1, a temporary's slot is reused once its last reader has run. Writes the ops
  // to `ops`, the wanted wires' slots to `outputs`; returns the number of slots (sink included).
  // `Flags` and `Ints` are scratch vectors with one entry per wire, `Free` a stack of slots.
  template <class Flags, class Ints, class Free, class Ops, class Outs>
  constexpr int Compile(const List& wanted, Flags& needed, Ints& last_use, Ints& slot, Free& free,
                        Ops& ops, Outs& outputs) const {
    for (int w = 0; w < next_wire_; ++w) {
      needed.push_back(0);
      last_use.push_back(-1);
      slot.push_back(w < inputs_ ? w : -1);
    }
    for (int i = 0; i < wanted.size(); ++i) needed[wanted[i]] = 1;
    for (int i = comparators_.size() - 1; i >= 0; --i) {
      const Comparator& c = comparators_[i];
      if (needed[c.lo] || needed[c.hi]) needed[c.a] = needed[c.b] = 1;
    }
    constexpr int kForever = 1 << 30;
    for (int i = 0; i < comparators_.size(); ++i) {
      const Comparator& c = comparators_[i];
      if (needed[c.lo] || needed[c.hi]) last_use[c.a] = last_use[c.b] = i;
    }
    for (int i = 0; i < wanted.size(); ++i) last_use[wanted[i]] = kForever;
    int slots = inputs_;
    // Pending ops hold -1 for an unneeded output until the sink's slot number is known.
    for (int i = 0; i < comparators_.size(); ++i) {
      const Comparator& c = comparators_[i];
      if (!needed[c.lo] && !needed[c.hi]) continue;
      const int a = slot[c.a], b = slot[c.b];
      for (int w : {c.a, c.b}) {
        if (w >= inputs_ && last_use[w] == i) free.push_back(slot[w]);
      }
      auto acquire = [&]() {
        if (free.empty()) return slots++;
        const int reused = free.back();
        free.pop_back();
        return reused;
      };
      const int lo = needed[c.lo] ? (slot[c.lo] = acquire()) : -1;
      const int hi = needed[c.hi] ? (slot[c.hi] = acquire()) : -1;
      ops.push_back(Op{a, b, lo, hi});
    }
    const int sink = slots;
    for (int i = 0; i < ops.size(); ++i) {
      if (ops[i].lo < 0) ops[i].lo = sink;
      if (ops[i].hi < 0) ops[i].hi = sink;
    }
    for (int i = 0; i < wanted.size(); ++i) outputs.push_back(slot[wanted[i]]);
    return sink + 1;
  }

 private:
  static constexpr List Stride(const List& v, int start) {
    List out{};
    for (int i = start; i < v.size(); i += 2) out.push_back(v[i]);
    return out;
  }

  constexpr void Compare(int& x, int& y) {
    const int lo = next_wire_++, hi = next_wire_++;
    comparators_.push_back(Comparator{x, y, lo, hi});
    x = lo;
    y = hi;
  }

  int inputs_;
  int next_wire_;
  Store comparators_{};
};

// The stages of the filter for window size k (odd, >= 3). Blocks of 2^j columns with
// 2^(j+1) <= k are kept for every x (a larger block or the core reads them at two offsets); the
// largest block of k's binary decomposition is merged inside the core network.
enum class Stage { kSortColumns, kMergeLevel, kCoreBand, kFinish };

constexpr int TopBlock(int k) {
  int j = 0;
  while ((2 << j) <= k) ++j;
  return j;  // 2^j <= k < 2^(j+1)
}

// Builds one stage's network: `level` (1-based) for kMergeLevel. Returns the wanted wires.
template <class List, class Store>
constexpr List BuildStage(NetworkBuilder<List, Store>& b, int k, Stage stage, int level) {
  using B = NetworkBuilder<List, Store>;
  const int rows = k - 1;
  switch (stage) {
    case Stage::kSortColumns:
      return b.Sort(B::Range(0, rows));
    case Stage::kMergeLevel: {
      const int size = rows << (level - 1);
      return b.Merge(B::Range(0, size), B::Range(size, size));
    }
    case Stage::kCoreBand: {
      // Inputs, in order: the two halves of the largest block, then the smaller blocks of k's
      // binary decomposition from large to small. Merging the small ones first costs fewer
      // comparators.
      const int top = TopBlock(k);
      const int half = rows << (top > 0 ? top - 1 : 0);
      List rest{};
      int wire = top > 0 ? 2 * half : half;
      List blocks_small[32]{};
      int n_small = 0;
      for (int j = top - 1; j >= 0; --j) {
        if (k & (1 << j)) {
          blocks_small[n_small++] = B::Range(wire, rows << j);
          wire += rows << j;
        }
      }
      for (int i = n_small - 1; i >= 0; --i) rest = b.Merge(blocks_small[i], rest);
      const List large =
          top > 0 ? b.Merge(B::Range(0, half), B::Range(half, half)) : B::Range(0, half);
      const List all = b.Merge(large, rest);
      const int median = (k * k - 1) / 2;
      List band{};
      for (int r = median - k; r <= median; ++r) band.push_back(all[r]);
      return band;
    }
    case Stage::kFinish: {
      const List all = b.Merge(B::Range(0, k + 1), b.Sort(B::Range(k + 1, k)));
      List out{};
      out.push_back(all[k]);
      return out;
    }
  }
  return List{};
}

constexpr int StageInputs(int k, Stage stage, int level) {
  const int rows = k - 1;
  switch (stage) {
    case Stage::kSortColumns:
      return rows;
    case Stage::kMergeLevel:
      return 2 * (rows << (level - 1));
    case Stage::kCoreBand:
      return rows * k;
    case Stage::kFinish:
      return 2 * k + 1;
  }
  return 0;
}

// A program for the interpreter (any k).
struct Program {
  int inputs = 0;
  int slots = 0;
  std::vector<Op> ops;
  std::vector<int> outputs;
};

Program RuntimeProgram(int k, Stage stage, int level) {
  NetworkBuilder<DynVec<int>, DynVec<Comparator>> b(StageInputs(k, stage, level));
  const DynVec<int> wanted = BuildStage(b, k, stage, level);
  DynVec<char> needed;
  DynVec<int> last_use, slot;
  DynVec<int> free;
  DynVec<Op> ops;
  DynVec<int> outputs;
  Program p;
  p.inputs = StageInputs(k, stage, level);
  p.slots = b.Compile(wanted, needed, last_use, slot, free, ops, outputs);
  p.ops.assign(ops.begin(), ops.end());
  p.outputs.assign(outputs.begin(), outputs.end());
  return p;
}

// ---------------------------------------------------------------------------------------------
// Running networks

// Interpreter for run-time programs: kChunk pixels per pass, each slot kChunk floats of scratch.
constexpr int kChunk = 32;

void InterpretChunk(const Program& p, float* slots) {
  for (const Op& op : p.ops) {
    float va[kChunk], vb[kChunk];
    std::copy_n(slots + op.a * kChunk, kChunk, va);
    std::copy_n(slots + op.b * kChunk, kChunk, vb);
    float* lo = slots + op.lo * kChunk;
    float* hi = slots + op.hi * kChunk;
    for (int j = 0; j < kChunk; ++j) {
      lo[j] = vb[j] < va[j] ? vb[j] : va[j];
      hi[j] = va[j] < vb[j] ? vb[j] : va[j];
    }
  }
}

void Interpret(const Program& p, const float* const* in, float* const* out, int n,
               std::vector<float>& scratch) {
  scratch.resize(static_cast<size_t>(p.slots) * kChunk);
  float* slots = scratch.data();
  for (int x0 = 0; x0 < n; x0 += kChunk) {
    for (int i = 0; i < p.inputs; ++i) std::copy_n(in[i] + x0, kChunk, slots + i * kChunk);
    InterpretChunk(p, slots);
    for (size_t j = 0; j < p.outputs.size(); ++j) {
      std::copy_n(slots + p.outputs[j] * kChunk, kChunk, out[j] + x0);
    }
  }
}

// The stages of one window size, whichever way they run. Each reads inputs in[i][x] and writes
// outputs out[j][x] for x in [0, n) rounded up to whole vectors (arrays carry slack for that).
class MedianStages {
 public:
  virtual ~MedianStages() = default;
  virtual void Run(Stage stage, int level, const float* const* in, float* const* out, int n,
                   std::vector<float>& scratch) const = 0;
};

class InterpretedStages : public MedianStages {
 public:
  explicit InterpretedStages(int k) {
    sort_ = RuntimeProgram(k, Stage::kSortColumns, 0);
    for (int level = 1; level < TopBlock(k); ++level) {
      merge_.push_back(RuntimeProgram(k, Stage::kMergeLevel, level));
    }
    core_ = RuntimeProgram(k, Stage::kCoreBand, 0);
    finish_ = RuntimeProgram(k, Stage::kFinish, 0);
  }
  void Run(Stage stage, int level, const float* const* in, float* const* out, int n,
           std::vector<float>& scratch) const override {
    const Program& p = stage == Stage::kSortColumns  ? sort_
                       : stage == Stage::kMergeLevel ? merge_[level - 1]
                       : stage == Stage::kCoreBand   ? core_
                                                     : finish_;
    Interpret(p, in, out, n, scratch);
  }

 private:
  Program sort_, core_, finish_;
  std::vector<Program> merge_;
};

#ifdef TURBID_MEDIAN_AVX2
// The same network as a constant: sizes and ops known to the compiler.
constexpr int kMaxWires = 4096;
using ConstList = FixedVec<int, 256>;
using ConstBuilder = NetworkBuilder<ConstList, FixedVec<Comparator, kMaxWires / 2>>;

template <int K, Stage S, int L>
struct ConstProgram {
  struct Built {
    FixedVec<Op, kMaxWires / 2> ops;
    FixedVec<int, 64> outputs;
    int slots = 0;
  };
  static constexpr Built Build() {
    ConstBuilder b(StageInputs(K, S, L));
    const ConstList wanted = BuildStage(b, K, S, L);
    FixedVec<char, kMaxWires> needed;
    FixedVec<int, kMaxWires> last_use, slot;
    FixedVec<int, kMaxWires> free;
    Built built;
    built.slots = b.Compile(wanted, needed, last_use, slot, free, built.ops, built.outputs);
    return built;
  }
  static constexpr Built kBuilt = Build();
  static constexpr int kInputs = StageInputs(K, S, L);
  static constexpr int kSlots = kBuilt.slots;
  static constexpr int kOps = kBuilt.ops.size();
  static constexpr int kOutputs = kBuilt.outputs.size();
};

// Straight-line code for a constant program, on vectors of lanes pixels. `Lanes` supplies the
// vector type V and Load/Store/Min/Max.
#define TURBID_AVX2_FN __attribute__((target("avx2"))) inline

template <class Lanes, Op kOp>
TURBID_AVX2_FN void ApplyOp(typename Lanes::V* v) {
  const typename Lanes::V a = v[kOp.a], b = v[kOp.b];
  v[kOp.lo] = Lanes::Min(a, b);
  v[kOp.hi] = Lanes::Max(a, b);
}

template <class Lanes, class P, size_t... I>
TURBID_AVX2_FN void ApplyOps(typename Lanes::V* v, std::index_sequence<I...>) {
  (ApplyOp<Lanes, P::kBuilt.ops[I]>(v), ...);
}

template <class Lanes, class P, size_t... I>
TURBID_AVX2_FN void LoadInputs(typename Lanes::V* v, const float* const* in, int x,
                               std::index_sequence<I...>) {
  ((v[I] = Lanes::Load(in[I] + x)), ...);
}

template <class Lanes, class P, size_t... I>
TURBID_AVX2_FN void StoreOutputs(const typename Lanes::V* v, float* const* out, int x,
                                 std::index_sequence<I...>) {
  (Lanes::Store(out[I] + x, v[P::kBuilt.outputs[I]]), ...);
}

template <class Lanes, class P>
TURBID_AVX2_FN void RunConst(const float* const* in, float* const* out, int n) {
  for (int x = 0; x < n; x += Lanes::kWidth) {
    typename Lanes::V v[P::kSlots];
    LoadInputs<Lanes, P>(v, in, x, std::make_index_sequence<P::kInputs>());
    ApplyOps<Lanes, P>(v, std::make_index_sequence<P::kOps>());
    StoreOutputs<Lanes, P>(v, out, x, std::make_index_sequence<P::kOutputs>());
  }
}

// min/max give the same values as the portable lanes: one of the two inputs (never NaN here).
struct Avx2Lanes {
  static constexpr int kWidth = 8;
  using V = __m256;
  static TURBID_AVX2_FN V Load(const float* p) { return _mm256_loadu_ps(p); }
  static TURBID_AVX2_FN void Store(float* p, V v) { _mm256_storeu_ps(p, v); }
  static TURBID_AVX2_FN V Min(V a, V b) { return _mm256_min_ps(a, b); }
  static TURBID_AVX2_FN V Max(V a, V b) { return _mm256_max_ps(a, b); }
};

// k = 11 (Tarel's default window) compiled to straight-line code.
using Sort11 = ConstProgram<11, Stage::kSortColumns, 0>;
using Merge11a = ConstProgram<11, Stage::kMergeLevel, 1>;
using Merge11b = ConstProgram<11, Stage::kMergeLevel, 2>;
using Core11 = ConstProgram<11, Stage::kCoreBand, 0>;
using Finish11 = ConstProgram<11, Stage::kFinish, 0>;
static_assert(TopBlock(11) == 3, "k = 11 keeps blocks of 2 and 4 columns");

__attribute__((target("avx2"), flatten)) void Run11Avx2(Stage stage, int level,
                                                        const float* const* in, float* const* out,
                                                        int n) {
  switch (stage) {
    case Stage::kSortColumns:
      return RunConst<Avx2Lanes, Sort11>(in, out, n);
    case Stage::kMergeLevel:
      return level == 1 ? RunConst<Avx2Lanes, Merge11a>(in, out, n)
                        : RunConst<Avx2Lanes, Merge11b>(in, out, n);
    case Stage::kCoreBand:
      return RunConst<Avx2Lanes, Core11>(in, out, n);
    case Stage::kFinish:
      return RunConst<Avx2Lanes, Finish11>(in, out, n);
  }
}

class CompiledStages11 : public MedianStages {
 public:
  void Run(Stage stage, int level, const float* const* in, float* const* out, int n,
           std::vector<float>& /*scratch*/) const override {
    Run11Avx2(stage, level, in, out, n);
  }
};
#endif  // TURBID_MEDIAN_AVX2

const MedianStages& StagesFor(int k, bool compiled) {
  static std::mutex mutex;
  static std::map<std::pair<int, bool>, std::unique_ptr<MedianStages>> stages;
  std::lock_guard<std::mutex> lock(mutex);
  auto& s = stages[{k, compiled}];
  if (!s) {
#ifdef TURBID_MEDIAN_AVX2
    if (compiled) s = std::make_unique<CompiledStages11>();
#endif
    if (!s) s = std::make_unique<InterpretedStages>(k);
  }
  return *s;
}

// ---------------------------------------------------------------------------------------------
// The filter

// Rows of floats with a common stride.
struct Planes {
  int stride = 0;
  std::vector<float> data;
  void Reset(int count, int s) {
    stride = s;
    data.assign(static_cast<size_t>(count) * s, 0.0f);
  }
  float* Row(int i) { return data.data() + static_cast<size_t>(i) * stride; }
};

}  // namespace

namespace {

// One NetworkMedian run: the padded input ring, the sorted levels and the band, and the stage
// calls of each pair of output rows.
class MedianRun {
 public:
  MedianRun(const cv::Mat& image, int k, const MedianStages& stages)
      : image_(image),
        stages_(stages),
        k_(k),
        half_(k / 2),
        rows_(k - 1),
        top_(TopBlock(k)),
        width_(image.cols),
        wp_(image.cols + 2 * (k / 2)),
        ring_(k + 2) {
    // Slack: whole vectors or chunks past n, read at offsets up to k - 1.
    const int stride = (wp_ + 2 * kChunk + k + 7) / 8 * 8;
    // Padded input rows (border: reflect) in a ring of k + 2: a pair of output rows reads k + 1.
    input_.Reset(ring_, stride);
    ring_row_.assign(ring_, -1);
    column_source_.resize(wp_);
    for (int x = 0; x < wp_; ++x)
      column_source_[x] = cv::borderInterpolate(x - half_, width_, cv::BORDER_REFLECT);
    // Sorted core columns (level 0) and blocks of 2^j columns (level j), k-1 rows each.
    levels_.resize(top_ > 0 ? top_ : 1);
    for (size_t j = 0; j < levels_.size(); ++j) levels_[j].Reset(rows_ << j, stride);
    band_.Reset(k + 1, stride);
    result_.Reset(1, stride);
  }

  // Output rows y and y+1 are padded rows y+half and y+1+half: core = padded rows y+1 .. y+k-1;
  // private rows y (output y) and y+k (output y+1; past the image for an odd last row, then
  // unused).
  void RowPair(int y, cv::Mat& filtered) {
    SortCore(y);
    CoreBand();
    for (int side = 0; side < 2 && y + side < image_.rows; ++side) {
      Begin();
      for (int r = 0; r <= k_; ++r) in_.push_back(band_.Row(r));
      const float* own = PaddedRow(side == 0 ? y : y + k_);
      for (int dx = 0; dx < k_; ++dx) in_.push_back(own + dx);
      out_.push_back(result_.Row(0));
      stages_.Run(Stage::kFinish, 0, in_.data(), out_.data(), width_, scratch_);
      std::copy_n(result_.Row(0), width_, filtered.ptr<float>(y + side));
    }
  }

 private:
  void Begin() {
    in_.clear();
    out_.clear();
  }

  const float* PaddedRow(int py) {
    float* row = input_.Row(py % ring_);
    if (ring_row_[py % ring_] != py) {
      ring_row_[py % ring_] = py;
      const int sy = std::min(cv::borderInterpolate(py - half_, image_.rows, cv::BORDER_REFLECT),
                              image_.rows - 1);
      const float* src = image_.ptr<float>(sy);
      for (int x = 0; x < half_; ++x) row[x] = src[column_source_[x]];
      std::copy_n(src, width_, row + half_);
      for (int x = half_ + width_; x < wp_; ++x) row[x] = src[column_source_[x]];
    }
    return row;
  }

  // The core's columns sorted (level 0), then merged into blocks of 2^j columns.
  void SortCore(int y) {
    Begin();
    for (int r = 0; r < rows_; ++r) in_.push_back(PaddedRow(y + 1 + r));
    for (int r = 0; r < rows_; ++r) out_.push_back(levels_[0].Row(r));
    stages_.Run(Stage::kSortColumns, 0, in_.data(), out_.data(), wp_, scratch_);
    for (int j = 1; j < top_; ++j) {
      Begin();
      for (int shift : {0, 1 << (j - 1)}) {
        for (int r = 0; r < (rows_ << (j - 1)); ++r) in_.push_back(levels_[j - 1].Row(r) + shift);
      }
      for (int r = 0; r < (rows_ << j); ++r) out_.push_back(levels_[j].Row(r));
      stages_.Run(Stage::kMergeLevel, j, in_.data(), out_.data(), wp_ - (1 << j) + 1, scratch_);
    }
  }

  // The k + 1 sorted values every output pixel of the pair shares, from the largest blocks.
  void CoreBand() {
    Begin();
    const int largest_half = top_ > 0 ? top_ - 1 : 0;
    for (int shift : {0, 1 << largest_half}) {
      if (top_ == 0 && shift > 0) break;
      for (int r = 0; r < (rows_ << largest_half); ++r) {
        in_.push_back(levels_[largest_half].Row(r) + shift);
      }
    }
    int offset = 1 << top_;
    for (int j = top_ - 1; j >= 0; --j) {
      if (!(k_ & (1 << j))) continue;
      for (int r = 0; r < (rows_ << j); ++r) in_.push_back(levels_[j].Row(r) + offset);
      offset += 1 << j;
    }
    for (int r = 0; r <= k_; ++r) out_.push_back(band_.Row(r));
    stages_.Run(Stage::kCoreBand, 0, in_.data(), out_.data(), width_, scratch_);
  }

  const cv::Mat& image_;
  const MedianStages& stages_;
  const int k_, half_, rows_, top_, width_, wp_, ring_;
  Planes input_, band_, result_;
  std::vector<Planes> levels_;
  std::vector<int> ring_row_, column_source_;
  std::vector<float> scratch_;
  std::vector<const float*> in_;
  std::vector<float*> out_;
};

}  // namespace

cv::Mat NetworkMedian(const cv::Mat& image, int k, bool allow_compiled) {
  CV_Assert(image.type() == CV_32FC1 && k >= 3 && k % 2 == 1);
  const MedianStages& stages =
      StagesFor(k, allow_compiled && k == 11 && enhancer_internal::UseHandWrittenAvx2());
  MedianRun run(image, k, stages);
  cv::Mat filtered(image.size(), CV_32FC1);
  for (int y = 0; y < image.rows; y += 2) run.RowPair(y, filtered);
  return filtered;
}

}  // namespace baselines_internal
}  // namespace turbid
