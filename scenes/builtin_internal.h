// Internals of the built-in scenes (scenes/builtin.cc), exposed for the tests; not part of the API.
#pragma once

#include <cstdint>

namespace turbid::builtin_internal {

// false makes the textures that have a vectorised version (the hull's) use their scalar code
// instead; both give the same bytes (hull, seafloor sand and rocks). Default true. Process-wide.
void SetBuiltinVectorTextures(bool enabled);

// The hull texture's four fractal sums at n plate points (u[k], v[k]), metres, as the texture
// computes them (vectorised unless switched off): out[4k .. 4k + 3] = paint, speckle, streaks,
// fouling patch.
void BuiltinHullNoiseForTest(const double* u, const double* v, int n, double* out);

// The seafloor sand texture's five value-noise terms and its shells' cellular noise at n plane
// points (u[k], v[k]), metres, as the texture computes them (vectorised unless switched off):
// out[7k .. 7k + 6] = shade, ripple phase, grain, patch, patch grain, shell distance, shell id.
void BuiltinSandNoiseForTest(const double* u, const double* v, int n, double* out);

// The seafloor rock texture's three fractal sums (Fbm3) at n points of a rock's own frame
// (xyz[3k .. 3k + 2], metres) for the rock's `seed`, as the texture computes them (vectorised
// unless switched off): out[3k .. 3k + 2] = shade, vein, growth.
void BuiltinRockNoiseForTest(const double* xyz, int n, uint32_t seed, double* out);

// The cellular noise of the textures (hull barnacles, seafloor pebbles): the distance from (x, y)
// to the nearest of the 3 x 3 cells' feature points (std::hypot) and that point's id.
void Cellular2ForTest(double x, double y, uint32_t seed, double* distance, double* id);

}  // namespace turbid::builtin_internal
