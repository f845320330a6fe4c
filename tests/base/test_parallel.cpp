#include "base/parallel.hpp"
#include "base/progress.hpp"

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>

using namespace dgv;

namespace {
double sumWith(std::size_t threads, Index n) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    return parallelReduce<double>(
        n, 0.0, [](double& acc, Index i) { acc += std::sin(0.001 * double(i)) * 1e-3 + 1.0 / double(i + 1); },
        [](double a, double b) { return a + b; }, 997);
}
}  // namespace

TEST_CASE("parallel: parallelFor visits every index exactly once", "[base]") {
    const Index n = 100003;
    std::vector<int> hits(static_cast<std::size_t>(n), 0);
    parallelFor(
        n, [&](Index i) { hits[static_cast<std::size_t>(i)] += 1; }, 64);
    for (int h : hits) REQUIRE(h == 1);
    std::vector<int> blocks(static_cast<std::size_t>(n), 0);
    parallelForBlocks(
        n,
        [&](Index b, Index e) {
            for (Index i = b; i < e; ++i) blocks[static_cast<std::size_t>(i)]++;
        },
        100);
    for (int h : blocks) REQUIRE(h == 1);
}

TEST_CASE("parallel: parallelReduce is bit-identical for 1 and 2 threads", "[base][determinism]") {
    const Index n = 1000000;
    double one = sumWith(1, n);
    double two = sumWith(2, n);
    double four = sumWith(4, n);
    CHECK(std::memcmp(&one, &two, sizeof one) == 0);
    CHECK(std::memcmp(&one, &four, sizeof one) == 0);
    // and it is the sum: harmonic number H_n ~ ln n + gamma + 1/(2n)
    double harmonic = std::log(double(n)) + 0.5772156649015329 + 0.5 / double(n);
    double sines = 0;
    for (Index i = 0; i < n; ++i) sines += std::sin(0.001 * double(i)) * 1e-3;
    CHECK(one == Approx(harmonic + sines).epsilon(1e-12));
}

TEST_CASE("parallel: empty and tiny ranges", "[base]") {
    int calls = 0;
    parallelFor(0, [&](Index) { ++calls; });
    CHECK(calls == 0);
    CHECK(parallelReduce<int>(
              0, 7, [](int& a, Index) { ++a; }, [](int a, int b) { return a + b; }) == 7);
    CHECK(parallelReduce<int>(
              5, 0, [](int& a, Index) { ++a; }, [](int a, int b) { return a + b; }) == 5);
}

TEST_CASE("progress: durations format as M:SS and H:MM:SS", "[base]") {
    CHECK(formatDuration(0) == "0:00");
    CHECK(formatDuration(65.4) == "1:05");
    CHECK(formatDuration(3725) == "1:02:05");
    CHECK(formatDuration(-1) == "?");
    CHECK(formatDuration(std::nan("")) == "?");
}

TEST_CASE("progress: cancellation flag", "[base]") {
    resetCancel();
    CHECK_FALSE(cancelRequested());
    requestCancel();
    CHECK(cancelRequested());
    resetCancel();
    CHECK_FALSE(cancelRequested());
}
