// Tests only: a switch between the hand-written AVX2 row kernels of the guided filter and CLAHE
// and their portable versions (plain loops the compiler vectorises). Both give the same results
// bit for bit; on an AVX2 machine the portable ones would otherwise never run, so tests turn the
// hand-written ones off to check that. Default: on (where the CPU has AVX2).
#pragma once

namespace turbid::enhancer_internal {

void SetHandWrittenAvx2(bool enabled);
// True when the CPU has AVX2 and the switch is on.
bool UseHandWrittenAvx2();

}  // namespace turbid::enhancer_internal
