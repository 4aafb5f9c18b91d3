// Internals of the built-in scenes (scenes/builtin.cc), exposed for the tests; not part of the API.
#pragma once

namespace turbid::builtin_internal {

// false makes the textures that have a vectorised version (the hull's) use their scalar code
// instead; both give the same bytes. Default true. Process-wide.
void SetBuiltinVectorTextures(bool enabled);

// The hull texture's four fractal sums at n plate points (u[k], v[k]), metres, as the texture
// computes them (vectorised unless switched off): out[4k .. 4k + 3] = paint, speckle, streaks,
// fouling patch.
void BuiltinHullNoiseForTest(const double* u, const double* v, int n, double* out);

}  // namespace turbid::builtin_internal
