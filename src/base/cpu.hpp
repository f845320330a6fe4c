#pragma once
/// @file cpu.hpp
/// @brief What the CPU running us can do, for kernels compiled for more than the baseline
/// (x86-64 SSE2): the GLN direct kernel and the VDB resampler pick their AVX2 (and AVX-512) versions by it.

namespace dgv {

/// True where the CPU executes AVX2 (decided once).
inline bool cpuHasAvx2() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    static const bool has = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    }();
    return has;
#else
    return false;
#endif
}

/// True where the CPU executes AVX-512F and the OS saves the zmm registers (decided once; GCC's
/// check covers both).
inline bool cpuHasAvx512f() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    static const bool has = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512f") != 0;
    }();
    return has;
#else
    return false;
#endif
}

}  // namespace dgv
