#pragma once
/// @file cpu.hpp
/// @brief What the CPU running us can do, for kernels compiled for more than the baseline
/// (x86-64 SSE2): the GLN direct kernel and the VDB resampler pick their AVX2 versions by it.

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

}  // namespace dgv
