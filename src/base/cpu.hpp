#pragma once
/// @file cpu.hpp
/// @brief What the CPU running us can do, for kernels compiled for more than the baseline
/// (x86-64 SSE2): the GLN direct kernel and the VDB resampler pick their AVX2 (and AVX-512)
/// versions by it.

namespace dgv {

/// The instruction-set extensions dgv has kernels for, probed once.
struct CpuFeatures {
    bool avx2 = false;
    bool avx512f = false;  ///< AVX-512F, with the zmm registers saved by the OS (GCC checks both)
};

inline const CpuFeatures& cpuFeatures() {
    static const CpuFeatures features = [] {
        CpuFeatures f;
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
        __builtin_cpu_init();
        f.avx2 = __builtin_cpu_supports("avx2") != 0;
        f.avx512f = __builtin_cpu_supports("avx512f") != 0;
#endif
        return f;
    }();
    return features;
}

/// True where the CPU executes AVX2.
inline bool cpuHasAvx2() { return cpuFeatures().avx2; }

/// True where the CPU executes AVX-512F.
inline bool cpuHasAvx512f() { return cpuFeatures().avx512f; }

}  // namespace dgv
