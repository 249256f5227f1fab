// The step's kernels are compiled for x86-64-v4 (AVX-512: 32 vector registers), v3
// (AVX2) and the baseline, and the loader picks the best the CPU has. Floating-point
// contraction is off for the engine (CMakeLists.txt), so the three give the same bits.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(GRANARY_NO_KERNEL_CLONES)
#define GRANARY_KERNEL __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define GRANARY_KERNEL
#endif
