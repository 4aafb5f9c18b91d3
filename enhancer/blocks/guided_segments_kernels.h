// The row kernels of guided_segments.h written once over a vector type: `O` supplies V (8
// floats, one per segment), Load / Store (32-byte aligned), Add, Sub, Mul, Div, Set1, MulAdd
// (a b + c) and NegMulAdd (c - a b). Included by guided_segments.cc (portable V) and
// guided_segments_avx2.cc (__m256, FMA) inside an anonymous namespace, so each copy is internal to
// its file.

// The column of a segment row: 3 channels x 8 lanes.
inline float* SegCol(float* p, int j, int c) { return p + (static_cast<ptrdiff_t>(j) * 3 + c) * 8; }
inline const float* SegCol(const float* p, int j, int c) {
  return p + (static_cast<ptrdiff_t>(j) * 3 + c) * 8;
}

// Horizontal sums restart from a direct sum every this many columns (float drift bounded).
constexpr int kAnchorCols = 64;

// Column j of two planes' column sums += (add - sub) (second plane: its own rows, or the squares
// of the first plane's when kSquare); kAdd / kSub: whether those rows are there.
// The window sums of both planes and three channels (or one column of them), kept in registers.
template <class O>
struct Sums {
  typename O::V s0[3], s1[3];
};

template <class O, bool kSquare, bool kAdd, bool kSub>
inline void UpdateColumn(float* c0, float* c1, const float* add0, const float* sub0,
                         const float* add1, const float* sub1, int j, Sums<O>& col) {
  using V = typename O::V;
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    float* p0 = SegCol(c0, j, c);
    float* p1 = SegCol(c1, j, c);
    V x0 = O::Load(p0), x1 = O::Load(p1);
    if (kAdd && kSub) {
      const V a = O::Load(SegCol(add0, j, c)), s = O::Load(SegCol(sub0, j, c));
      x0 = O::Add(x0, O::Sub(a, s));
      if (kSquare) {
        x1 = O::Add(x1, O::Mul(O::Sub(a, s), O::Add(a, s)));
      } else {
        x1 = O::Add(x1, O::Sub(O::Load(SegCol(add1, j, c)), O::Load(SegCol(sub1, j, c))));
      }
    } else if (kAdd) {
      const V a = O::Load(SegCol(add0, j, c));
      x0 = O::Add(x0, a);
      x1 = kSquare ? O::MulAdd(a, a, x1) : O::Add(x1, O::Load(SegCol(add1, j, c)));
    } else if (kSub) {
      const V s = O::Load(SegCol(sub0, j, c));
      x0 = O::Sub(x0, s);
      x1 = kSquare ? O::NegMulAdd(s, s, x1) : O::Sub(x1, O::Load(SegCol(sub1, j, c)));
    }
    O::Store(p0, x0);
    O::Store(p1, x1);
    col.s0[c] = x0;
    col.s1[c] = x1;
  }
}

// Column j of two planes as it is.
template <class O>
inline void LoadColumn(const float* c0, const float* c1, int j, Sums<O>& col) {
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    col.s0[c] = O::Load(SegCol(c0, j, c));
    col.s1[c] = O::Load(SegCol(c1, j, c));
  }
}

// Window sums over columns [j, j + w] of two planes, summed directly.
template <class O>
inline void DirectWindow(const float* c0, const float* c1, int j, int w, Sums<O>& s) {
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    typename O::V x0 = O::Load(SegCol(c0, j, c)), x1 = O::Load(SegCol(c1, j, c));
    for (int i = 1; i <= w; ++i) {
      x0 = O::Add(x0, O::Load(SegCol(c0, j + i, c)));
      x1 = O::Add(x1, O::Load(SegCol(c1, j + i, c)));
    }
    s.s0[c] = x0;
    s.s1[c] = x1;
  }
}

// The sums of column j from those of j - 1: plus column j + w (`add`), minus column j - 1.
template <class O>
inline void RunningWindow(const float* c0, const float* c1, int j, const Sums<O>& add, Sums<O>& s) {
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    s.s0[c] = O::Add(s.s0[c], O::Sub(add.s0[c], O::Load(SegCol(c0, j - 1, c))));
    s.s1[c] = O::Add(s.s1[c], O::Sub(add.s1[c], O::Load(SegCol(c1, j - 1, c))));
  }
}

// The column loop shared by both stages: update(j, col) brings column j of the column sums up to
// date and returns it in col, emit(j, sums) uses the window sums over columns [j, j + w] for j in
// [0, count). The sums restart from a direct sum every kAnchorCols columns.
template <class O, typename Update, typename Emit>
inline void WindowLoop(const float* c0, const float* c1, int count, int w, Update&& update,
                       Emit&& emit) {
  Sums<O> s, col;
  for (int j = 0; j < w; ++j) update(j, col);
  for (int j0 = 0; j0 < count; j0 += kAnchorCols) {
    update(j0 + w, col);
    DirectWindow<O>(c0, c1, j0, w, s);
    emit(j0, s);
    const int j1 = j0 + kAnchorCols < count ? j0 + kAnchorCols : count;
    for (int j = j0 + 1; j < j1; ++j) {
      update(j + w, col);
      RunningWindow<O>(c0, c1, j, col, s);
      emit(j, s);
    }
  }
}

template <class O, bool kUpdate, bool kAdd, bool kSub>
void StageAImpl(const turbid::guided_segments::Geometry& g, float* c_i, float* c_ii,
                const float* add, const float* sub, const float* inv_x, float inv_y, float eps,
                float* a, float* b) {
  using V = typename O::V;
  const V ve = O::Set1(eps), vy = O::Set1(inv_y);
  WindowLoop<O>(
      c_i, c_ii, g.la, 2 * g.r,
      [&](int j, Sums<O>& col) {
        if (kUpdate) {
          UpdateColumn<O, true, kAdd, kSub>(c_i, c_ii, add, sub, nullptr, nullptr, j, col);
        } else {
          LoadColumn<O>(c_i, c_ii, j, col);
        }
      },
      [&](int j, const Sums<O>& s) {
        const V inv = O::Mul(O::Load(inv_x + static_cast<ptrdiff_t>(j) * 8), vy);
#pragma GCC unroll 3
        for (int c = 0; c < 3; ++c) {
          const V m = O::Mul(s.s0[c], inv);
          const V var = O::NegMulAdd(m, m, O::Mul(s.s1[c], inv));
          const V av = O::Div(var, O::Add(var, ve));
          O::Store(SegCol(a, j, c), av);
          O::Store(SegCol(b, j, c), O::NegMulAdd(av, m, m));
        }
      });
}

template <class O, bool kUpdate, bool kAdd, bool kSub>
void StageBImpl(const turbid::guided_segments::Geometry& g, float* c_a, float* c_b,
                const float* add_a, const float* sub_a, const float* add_b, const float* sub_b,
                const float* inv_x, float inv_y, const float* guide, float* q) {
  using V = typename O::V;
  const int w = 2 * g.r;
  const V vy = O::Set1(inv_y);
  WindowLoop<O>(
      c_a, c_b, g.L, w,
      [&](int j, Sums<O>& col) {
        if (kUpdate) {
          UpdateColumn<O, false, kAdd, kSub>(c_a, c_b, add_a, sub_a, add_b, sub_b, j, col);
        } else {
          LoadColumn<O>(c_a, c_b, j, col);
        }
      },
      [&](int s, const Sums<O>& sums) {
        const V inv = O::Mul(O::Load(inv_x + static_cast<ptrdiff_t>(s) * 8), vy);
#pragma GCC unroll 3
        for (int c = 0; c < 3; ++c) {
          const V i = O::Load(SegCol(guide, s + w, c));
          O::Store(SegCol(q, s, c), O::Mul(O::MulAdd(sums.s0[c], i, sums.s1[c]), inv));
        }
      });
}

// The variants by which rows are there (update false: the column sums are current).
template <class O>
void StageAKernel(const turbid::guided_segments::Geometry& g, float* c_i, float* c_ii,
                  const float* add, const float* sub, bool update, const float* inv_x, float inv_y,
                  float eps, float* a, float* b) {
  const bool has_add = update && add != nullptr, has_sub = update && sub != nullptr;
  if (has_add && has_sub) {
    StageAImpl<O, true, true, true>(g, c_i, c_ii, add, sub, inv_x, inv_y, eps, a, b);
  } else if (has_add) {
    StageAImpl<O, true, true, false>(g, c_i, c_ii, add, sub, inv_x, inv_y, eps, a, b);
  } else if (has_sub) {
    StageAImpl<O, true, false, true>(g, c_i, c_ii, add, sub, inv_x, inv_y, eps, a, b);
  } else {
    StageAImpl<O, false, false, false>(g, c_i, c_ii, add, sub, inv_x, inv_y, eps, a, b);
  }
}

template <class O>
void StageBKernel(const turbid::guided_segments::Geometry& g, float* c_a, float* c_b,
                  const float* add_a, const float* sub_a, const float* add_b, const float* sub_b,
                  bool update, const float* inv_x, float inv_y, const float* guide, float* q) {
  const bool has_add = update && add_a != nullptr, has_sub = update && sub_a != nullptr;
  if (has_add && has_sub) {
    StageBImpl<O, true, true, true>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, inv_x, inv_y, guide,
                                    q);
  } else if (has_add) {
    StageBImpl<O, true, true, false>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, inv_x, inv_y, guide,
                                     q);
  } else if (has_sub) {
    StageBImpl<O, true, false, true>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, inv_x, inv_y, guide,
                                     q);
  } else {
    StageBImpl<O, false, false, false>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, inv_x, inv_y, guide,
                                       q);
  }
}
