#pragma once
/// @file parallel.hpp
/// @brief Deterministic parallel loops over [0, n) on TBB.
///
/// parallelFor: each index is visited once; results written per index are therefore identical
/// for any thread count. parallelReduce: the range is cut into fixed blocks (independent of the
/// thread count), each block is reduced in index order, and the block results are combined in
/// block order, so floating-point sums are bit-identical for 1, 2 or N threads.

#include "base/types.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <utility>
#include <vector>

namespace dgv {

/// Number of indices per task; small loops run inline.
inline constexpr Index kParallelGrain = 2048;

/// Calls f(i) for every i in [0, n), in parallel.
template <typename F>
void parallelFor(Index n, F&& f, Index grain = kParallelGrain) {
    if (n <= 0) return;
    if (n <= grain) {
        for (Index i = 0; i < n; ++i) f(i);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, grain), [&](const tbb::blocked_range<Index>& r) {
        for (Index i = r.begin(); i != r.end(); ++i) f(i);
    });
}

/// Calls f(begin, end) on consecutive blocks covering [0, n), in parallel.
template <typename F>
void parallelForBlocks(Index n, F&& f, Index grain = kParallelGrain) {
    if (n <= 0) return;
    if (n <= grain) {
        f(Index(0), n);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, grain),
                      [&](const tbb::blocked_range<Index>& r) { f(r.begin(), r.end()); });
}

/// Runs f() and g() concurrently (each is deterministic on its own).
template <typename F, typename G>
void parallelInvoke(F&& f, G&& g) {
    tbb::parallel_invoke(std::forward<F>(f), std::forward<G>(g));
}

/// Deterministic reduction: returns combine(...combine(identity, map(0..B-1))...) where the
/// blocks of `block` indices are reduced in order by `accumulate(acc, i)` and the per-block
/// results are combined left to right. Bit-identical for any thread count.
template <typename T, typename Accumulate, typename Combine>
T parallelReduce(Index n, const T& identity, Accumulate&& accumulate, Combine&& combine, Index block = kParallelGrain) {
    if (n <= 0) return identity;
    const Index blocks = (n + block - 1) / block;
    std::vector<T> partial(static_cast<std::size_t>(blocks), identity);
    parallelFor(
        blocks,
        [&](Index b) {
            T acc = identity;
            const Index end = std::min(n, (b + 1) * block);
            for (Index i = b * block; i < end; ++i) accumulate(acc, i);
            partial[static_cast<std::size_t>(b)] = acc;
        },
        1);
    T result = identity;
    for (const T& p : partial) result = combine(result, p);
    return result;
}

}  // namespace dgv
