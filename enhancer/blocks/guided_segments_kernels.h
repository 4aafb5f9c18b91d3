// The row kernels of guided_segments.h written once over a vector type: `O` supplies kLanes (the
// segments, 8 or 16), V (kLanes floats, one per segment), Load / Store (aligned), Add, Sub, Mul,
// Div, Set1, MulAdd (a b + c), NegMulAdd (c - a b), and M, ShiftBy(m), Shifted(M, x) (lane k of
// the result = lane k + m of x, zero where k + m is outside [0, kLanes)). Included by
// guided_segments.cc (portable V), guided_segments_avx2.cc (__m256, FMA) and
// guided_segments_avx512.cc (__m512) inside an anonymous namespace, so each copy is internal to its
// file.

// The column of a segment row: 3 channels x kLanes lanes.
template <class O>
inline float* SegCol(float* p, int j, int c) {
  return p + (static_cast<ptrdiff_t>(j) * 3 + c) * O::kLanes;
}
template <class O>
inline const float* SegCol(const float* p, int j, int c) {
  return p + (static_cast<ptrdiff_t>(j) * 3 + c) * O::kLanes;
}

// Horizontal sums restart from a direct sum every this many columns (float drift bounded).
constexpr int kAnchorCols = 64;

// The window sums of both planes and three channels (or one column of them), kept in registers.
template <class O>
struct Sums {
  typename O::V s0[3], s1[3];
};

// Columns [0, n) of two planes += (add - sub) (second plane: its own rows, or the squares of the
// first plane's when kSquare); kAdd / kSub: whether those rows are there. c0, c1 start at the
// first column to update; add*, sub* are rows of n columns.
template <class O, bool kSquare, bool kAdd, bool kSub>
inline void UpdateColumns(float* c0, float* c1, const float* add0, const float* sub0,
                          const float* add1, const float* sub1, int n) {
  using V = typename O::V;
  for (int i = 0; i < n * 3; ++i) {
    const ptrdiff_t at = static_cast<ptrdiff_t>(i) * O::kLanes;
    V x0 = O::Load(c0 + at), x1 = O::Load(c1 + at);
    if (kAdd && kSub) {
      const V a = O::Load(add0 + at), s = O::Load(sub0 + at);
      x0 = O::Add(x0, O::Sub(a, s));
      if (kSquare) {
        x1 = O::Add(x1, O::Mul(O::Sub(a, s), O::Add(a, s)));
      } else {
        x1 = O::Add(x1, O::Sub(O::Load(add1 + at), O::Load(sub1 + at)));
      }
    } else if (kAdd) {
      const V a = O::Load(add0 + at);
      x0 = O::Add(x0, a);
      x1 = kSquare ? O::MulAdd(a, a, x1) : O::Add(x1, O::Load(add1 + at));
    } else if (kSub) {
      const V s = O::Load(sub0 + at);
      x0 = O::Sub(x0, s);
      x1 = kSquare ? O::NegMulAdd(s, s, x1) : O::Sub(x1, O::Load(sub1 + at));
    }
    O::Store(c0 + at, x0);
    O::Store(c1 + at, x1);
  }
}

// The halo of two planes' column sums (lc = L + 2r columns, column r + s holding segment column s
// for s in [-r, L + r)): columns s < 0 and s >= L are the neighbouring segments' columns, one lane
// (or, where L < r, several) over: pixel k L + s is segment k + floor(s / L), column s mod L.
template <class O>
inline void FillHalo(const turbid::guided_segments::Geometry& g, float* c0, float* c1) {
  const int r = g.r, L = g.L;
  for (int t = 0; t < 2 * r; ++t) {
    const int s = t < r ? t - r : L + t - r;             // the halo column
    const int m = s >= 0 ? s / L : -((-s + L - 1) / L);  // floor(s / L)
    const typename O::M shift = O::ShiftBy(m);
    const ptrdiff_t to = static_cast<ptrdiff_t>(r + s) * 3 * O::kLanes;
    const ptrdiff_t from = static_cast<ptrdiff_t>(r + s - m * L) * 3 * O::kLanes;
#pragma GCC unroll 3
    for (int c = 0; c < 3; ++c) {
      O::Store(c0 + to + c * O::kLanes, O::Shifted(shift, O::Load(c0 + from + c * O::kLanes)));
      O::Store(c1 + to + c * O::kLanes, O::Shifted(shift, O::Load(c1 + from + c * O::kLanes)));
    }
  }
}

// Column j of two planes as it is.
template <class O>
inline void LoadColumn(const float* c0, const float* c1, int j, Sums<O>& col) {
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    col.s0[c] = O::Load(SegCol<O>(c0, j, c));
    col.s1[c] = O::Load(SegCol<O>(c1, j, c));
  }
}

// Window sums over columns [j, j + w] of two planes, summed directly.
template <class O>
inline void DirectWindow(const float* c0, const float* c1, int j, int w, Sums<O>& s) {
#pragma GCC unroll 3
  for (int c = 0; c < 3; ++c) {
    typename O::V x0 = O::Load(SegCol<O>(c0, j, c)), x1 = O::Load(SegCol<O>(c1, j, c));
    for (int i = 1; i <= w; ++i) {
      x0 = O::Add(x0, O::Load(SegCol<O>(c0, j + i, c)));
      x1 = O::Add(x1, O::Load(SegCol<O>(c1, j + i, c)));
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
    s.s0[c] = O::Add(s.s0[c], O::Sub(add.s0[c], O::Load(SegCol<O>(c0, j - 1, c))));
    s.s1[c] = O::Add(s.s1[c], O::Sub(add.s1[c], O::Load(SegCol<O>(c1, j - 1, c))));
  }
}

// The column loop shared by both stages: emit(j, sums) uses the window sums over columns
// [j, j + w] of c0, c1 for j in [0, count). The sums restart from a direct sum every kAnchorCols
// columns.
template <class O, typename Emit>
inline void WindowLoop(const float* c0, const float* c1, int count, int w, Emit&& emit) {
  Sums<O> s, col;
  for (int j0 = 0; j0 < count; j0 += kAnchorCols) {
    DirectWindow<O>(c0, c1, j0, w, s);
    emit(j0, s);
    const int j1 = j0 + kAnchorCols < count ? j0 + kAnchorCols : count;
    for (int j = j0 + 1; j < j1; ++j) {
      LoadColumn<O>(c0, c1, j + w, col);
      RunningWindow<O>(c0, c1, j, col, s);
      emit(j, s);
    }
  }
}

// Stage A: c_i, c_ii (lc columns) += rows add, sub (L columns) on columns [r, L + r) (kUpdate),
// their halo filled; a, b (L columns) from the window sums.
template <class O, bool kUpdate, bool kAdd, bool kSub>
void StageAImpl(const turbid::guided_segments::Geometry& g, float* c_i, float* c_ii,
                const float* add, const float* sub, const float* inv_x, float inv_y, float eps,
                float* a, float* b) {
  using V = typename O::V;
  const ptrdiff_t main = static_cast<ptrdiff_t>(g.r) * 3 * O::kLanes;
  if (kUpdate) {
    UpdateColumns<O, true, kAdd, kSub>(c_i + main, c_ii + main, add, sub, nullptr, nullptr, g.L);
  }
  FillHalo<O>(g, c_i, c_ii);
  const V ve = O::Set1(eps), vy = O::Set1(inv_y);
  WindowLoop<O>(c_i, c_ii, g.L, 2 * g.r, [&](int j, const Sums<O>& s) {
    const V inv = O::Mul(O::Load(inv_x + static_cast<ptrdiff_t>(j) * O::kLanes), vy);
#pragma GCC unroll 3
    for (int c = 0; c < 3; ++c) {
      const V m = O::Mul(s.s0[c], inv);
      const V var = O::NegMulAdd(m, m, O::Mul(s.s1[c], inv));
      const V av = O::Div(var, O::Add(var, ve));
      O::Store(SegCol<O>(a, j, c), av);
      O::Store(SegCol<O>(b, j, c), O::NegMulAdd(av, m, m));
    }
  });
}

// Stage B: the same on c_a, c_b from rows of a and b, q (L columns) with the guide row.
template <class O, bool kUpdate, bool kAdd, bool kSub>
void StageBImpl(const turbid::guided_segments::Geometry& g, float* c_a, float* c_b,
                const float* add_a, const float* sub_a, const float* add_b, const float* sub_b,
                const float* inv_x, float inv_y, const float* guide, float* q) {
  using V = typename O::V;
  const ptrdiff_t main = static_cast<ptrdiff_t>(g.r) * 3 * O::kLanes;
  if (kUpdate) {
    UpdateColumns<O, false, kAdd, kSub>(c_a + main, c_b + main, add_a, sub_a, add_b, sub_b, g.L);
  }
  FillHalo<O>(g, c_a, c_b);
  const V vy = O::Set1(inv_y);
  WindowLoop<O>(c_a, c_b, g.L, 2 * g.r, [&](int s, const Sums<O>& sums) {
    const V inv = O::Mul(O::Load(inv_x + static_cast<ptrdiff_t>(s) * O::kLanes), vy);
#pragma GCC unroll 3
    for (int c = 0; c < 3; ++c) {
      const V i = O::Load(SegCol<O>(guide, s, c));
      O::Store(SegCol<O>(q, s, c), O::Mul(O::MulAdd(sums.s0[c], i, sums.s1[c]), inv));
    }
  });
}

// Direct column sums over `count` rows (the every-kAnchorRows re-summing): c0 = sum of rows0[y],
// c1 = sum of rows1[y] (kSquare: of rows0[y]^2), y in [0, count) in order, over n floats (a
// multiple of 4 kLanes). Four vectors a step, summed in registers: each row read once, c0 and c1
// written once.
template <class O, bool kSquare>
void DirectColumnsImpl(size_t n, const float* const* rows0, const float* const* rows1, int count,
                       float* c0, float* c1) {
  using V = typename O::V;
  constexpr ptrdiff_t kStep = 4 * O::kLanes;
  for (ptrdiff_t i = 0; i < static_cast<ptrdiff_t>(n); i += kStep) {
    V x0[4], x1[4];
#pragma GCC unroll 4
    for (int u = 0; u < 4; ++u) x0[u] = x1[u] = O::Set1(0.0f);
    for (int y = 0; y < count; ++y) {
      const float* p = rows0[y] + i;
#pragma GCC unroll 4
      for (int u = 0; u < 4; ++u) {
        const V v = O::Load(p + u * O::kLanes);
        x0[u] = O::Add(x0[u], v);
        x1[u] =
            kSquare ? O::MulAdd(v, v, x1[u]) : O::Add(x1[u], O::Load(rows1[y] + i + u * O::kLanes));
      }
    }
#pragma GCC unroll 4
    for (int u = 0; u < 4; ++u) {
      O::Store(c0 + i + u * O::kLanes, x0[u]);
      O::Store(c1 + i + u * O::kLanes, x1[u]);
    }
  }
}

template <class O>
void DirectColumnsKernel(size_t n, const float* const* rows0, const float* const* rows1, int count,
                         float* c0, float* c1) {
  if (rows1 == nullptr) {
    DirectColumnsImpl<O, true>(n, rows0, rows1, count, c0, c1);
  } else {
    DirectColumnsImpl<O, false>(n, rows0, rows1, count, c0, c1);
  }
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
