#include "solve/multigrid.hpp"

#include "base/check.hpp"
#include "base/parallel.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <type_traits>

namespace dgv {

namespace {

using SpMat = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;
inline std::size_t at(Index i) { return static_cast<std::size_t>(i); }
constexpr int kMaxCols = 4;
constexpr Index kRowGrain = 1024;

SpMat toEigen(const SparseRows& a) {
    SpMat m(a.rows, a.rows);
    std::vector<Eigen::Triplet<Real, int>> t;
    t.reserve(a.value.size());
    for (Index i = 0; i < a.rows; ++i)
        for (int k = a.start[at(i)]; k < a.start[at(i) + 1]; ++k)
            t.emplace_back(static_cast<int>(i), a.column[static_cast<std::size_t>(k)],
                           a.value[static_cast<std::size_t>(k)]);
    m.setFromTriplets(t.begin(), t.end());
    return m;
}

SparseRows fromEigen(SpMat m) {
    m.makeCompressed();
    SparseRows a;
    a.rows = m.rows();
    a.start.assign(m.outerIndexPtr(), m.outerIndexPtr() + m.rows() + 1);
    a.column.assign(m.innerIndexPtr(), m.innerIndexPtr() + m.nonZeros());
    a.value.assign(m.valuePtr(), m.valuePtr() + m.nonZeros());
    return a;
}

/// Rectangular y = M x for C interleaved columns (M by rows), C known at compile time so that
/// the inner loop unrolls.
template <int C>
void multiplyRowsFixed(const int* start, const int* column, const Real* value, Index rows,
                       const Real* x, Real* y) {
    parallelForBlocks(
        rows,
        [&](Index b, Index e) {
            for (Index i = b; i < e; ++i) {
                Real acc[C] = {};
                const int end = start[i + 1];
                for (int k = start[i]; k < end; ++k) {
                    const Real v = value[k];
                    const Real* xr = x + std::ptrdiff_t(column[k]) * C;
                    for (int c = 0; c < C; ++c) acc[c] += v * xr[c];
                }
                for (int c = 0; c < C; ++c) y[i * C + c] = acc[c];
            }
        },
        kRowGrain);
}

/// Rectangular y = M x for `cols` interleaved columns (M by rows).
void multiplyRows(const std::vector<int>& start, const std::vector<int>& column,
                  const std::vector<Real>& value, Index rows, const Real* x, Real* y, int cols) {
    switch (cols) {
        case 1: multiplyRowsFixed<1>(start.data(), column.data(), value.data(), rows, x, y); break;
        case 2: multiplyRowsFixed<2>(start.data(), column.data(), value.data(), rows, x, y); break;
        case 3: multiplyRowsFixed<3>(start.data(), column.data(), value.data(), rows, x, y); break;
        default: multiplyRowsFixed<4>(start.data(), column.data(), value.data(), rows, x, y); break;
    }
}

using Sums = std::array<Real, kMaxCols>;

/// Per-column dot products of two rows x cols arrays (deterministic).
Sums columnDots(const Real* a, const Real* b, Index rows, int cols) {
    return parallelReduce(
        rows, Sums{0, 0, 0, 0},
        [&](Sums& s, Index i) {
            for (int c = 0; c < cols; ++c)
                s[std::size_t(c)] += a[at(i) * std::size_t(cols) + std::size_t(c)] *
                                     b[at(i) * std::size_t(cols) + std::size_t(c)];
        },
        [](Sums x, const Sums& y) {
            for (std::size_t c = 0; c < kMaxCols; ++c) x[c] += y[c];
            return x;
        },
        4096);
}

/// Fixed-block (4096 rows) reduction helpers of conjugateGradients: the same sums, in the same
/// order, as columnDots after the unfused loops.
template <int C>
Sums combineSums(Sums x, const Sums& y) {
    for (std::size_t c = 0; c < kMaxCols; ++c) x[c] += y[c];
    return x;
}

struct Level {
    SparseRows A;
    std::vector<Real> invDiag;
    Real lmin = 0, lmax = 0;
    SparseRows P;  ///< prolongation to this level from the next coarser one: rows = A.rows
    SparseRows R;  ///< P^T: rows = coarse rows
    /// A's values as floats when every one of them is exactly a float (the lattice Laplacian:
    /// small integers), else empty: the same products from half the value bytes.
    std::vector<float> valueF;
    mutable std::vector<Real> r, d, d2, t;  ///< work arrays (rows x cols)
};

/// acc = row i of M times x (C interleaved columns), entries in column order: the same
/// floating-point operations as multiplyRowsFixed. V: the value type (float only where exact).
template <int C, typename V>
inline void rowTimes(const int* start, const int* column, const V* value, Index i, const Real* x,
                     Real* acc) {
    for (int c = 0; c < C; ++c) acc[c] = 0;
    const int end = start[i + 1];
    for (int k = start[i]; k < end; ++k) {
        const Real v = Real(value[k]);
        const Real* xr = x + std::ptrdiff_t(column[k]) * C;
        for (int c = 0; c < C; ++c) acc[c] += v * xr[c];
    }
}

/// Calls f.template run<C, V>() with the level's column count and value type.
template <typename F>
void dispatch(const Level& L, int cols, F&& f) {
    const bool fl = !L.valueF.empty();
    switch (cols) {
        case 1: fl ? f.template run<1, float>() : f.template run<1, Real>(); break;
        case 2: fl ? f.template run<2, float>() : f.template run<2, Real>(); break;
        case 3: fl ? f.template run<3, float>() : f.template run<3, Real>(); break;
        default: fl ? f.template run<4, float>() : f.template run<4, Real>(); break;
    }
}

/// The fused passes of the V-cycle on one level. Each computes exactly the operations of the
/// unfused sequence (multiply into t, then the vector updates), row by row, so the results are
/// bit-identical to it; a pass never writes an array whose other rows it reads.
struct SmoothPasses {
    const Level& L;
    int cols;
    const Real* b;
    Real* x;
    const Real* xc = nullptr;  ///< coarse correction (prolongation pass)
    int degree = 2;
    Real theta = 0, sigma = 0, delta = 0;
    enum class Kind { Pre, Post, Residual, Prolong } kind = Kind::Pre;

    template <int C, typename V>
    const V* values() const {
        if constexpr (std::is_same_v<V, float>) return L.valueF.data();
        else return L.A.value.data();
    }

    /// Chebyshev steps 1..degree after d (step 0) is set in L.d; x already holds the start
    /// (or is assigned on the first step when `zero`).
    template <int C, typename V>
    void chebyshev(bool zero) {
        const int* st = L.A.start.data();
        const int* col = L.A.column.data();
        const V* val = values<C, V>();
        const Real* invDiag = L.invDiag.data();
        Real rho = Real(1) / sigma;
        Real* d = L.d.data();
        Real* dn = L.d2.data();
        Real* r = L.r.data();
        bool first = true;  // x not yet touched by any step
        for (int step = 1; step <= degree; ++step) {
            if (step == degree) {
                // x += d (x = d for a zero start with degree 1)
                Real* xx = x;
                const bool assign = zero && first;
                parallelForBlocks(L.A.rows, [&](Index b0, Index e0) {
                    for (std::size_t k = at(b0) * C; k < at(e0) * C; ++k)
                        xx[k] = assign ? d[k] : xx[k] + d[k];
                }, kRowGrain);
                break;
            }
            const Real rhoNew = Real(1) / (2 * sigma - rho);
            const Real c1 = rhoNew * rho, c2 = 2 * rhoNew / delta;
            const bool assign = zero && first;
            const bool last = step + 1 == degree;
            Real* xx = x;
            parallelForBlocks(L.A.rows, [&](Index b0, Index e0) {
                for (Index i = b0; i < e0; ++i) {
                    Real t[C];
                    rowTimes<C, V>(st, col, val, i, d, t);
                    for (int c = 0; c < C; ++c) {
                        const std::size_t k = at(i) * C + std::size_t(c);
                        const Real rk = r[k] - invDiag[i] * t[c];
                        const Real dk = c1 * d[k] + c2 * rk;
                        Real xk = assign ? d[k] : xx[k] + d[k];
                        if (last) {
                            xx[k] = xk + dk;  // r and d are not needed after the last step
                        } else {
                            xx[k] = xk;
                            r[k] = rk;
                            dn[k] = dk;
                        }
                    }
                }
            }, kRowGrain);
            std::swap(d, dn);
            rho = rhoNew;
            first = false;
            if (last) break;
        }
        // keep L.d / L.d2 pointing at distinct buffers for the next call
    }

    template <int C, typename V>
    void run() {
        const int* st = L.A.start.data();
        const int* col = L.A.column.data();
        const V* val = values<C, V>();
        const Real* invDiag = L.invDiag.data();
        Real* r = L.r.data();
        Real* d = L.d.data();
        Real* t = L.t.data();
        const Real* bb = b;
        Real* xx = x;
        switch (kind) {
            case Kind::Pre:
                parallelForBlocks(L.A.rows, [&](Index b0, Index e0) {
                    for (Index i = b0; i < e0; ++i)
                        for (int c = 0; c < C; ++c) {
                            const std::size_t k = at(i) * C + std::size_t(c);
                            r[k] = invDiag[i] * (bb[k] - Real(0));
                            d[k] = r[k] / theta;
                        }
                }, kRowGrain);
                chebyshev<C, V>(true);
                break;
            case Kind::Post:
                parallelForBlocks(L.A.rows, [&](Index b0, Index e0) {
                    for (Index i = b0; i < e0; ++i) {
                        Real ax[C];
                        rowTimes<C, V>(st, col, val, i, xx, ax);
                        for (int c = 0; c < C; ++c) {
                            const std::size_t k = at(i) * C + std::size_t(c);
                            r[k] = invDiag[i] * (bb[k] - ax[c]);
                            d[k] = r[k] / theta;
                        }
                    }
                }, kRowGrain);
                chebyshev<C, V>(false);
                break;
            case Kind::Residual:
                parallelForBlocks(L.A.rows, [&](Index b0, Index e0) {
                    for (Index i = b0; i < e0; ++i) {
                        Real ax[C];
                        rowTimes<C, V>(st, col, val, i, xx, ax);
                        for (int c = 0; c < C; ++c) t[at(i) * C + std::size_t(c)] = bb[at(i) * C + std::size_t(c)] - ax[c];
                    }
                }, kRowGrain);
                break;
            case Kind::Prolong: {
                const int* ps = L.P.start.data();
                const int* pc = L.P.column.data();
                const Real* pv = L.P.value.data();
                const Real* cc = xc;
                parallelForBlocks(L.P.rows, [&](Index b0, Index e0) {
                    for (Index i = b0; i < e0; ++i) {
                        Real px[C];
                        rowTimes<C, Real>(ps, pc, pv, i, cc, px);
                        for (int c = 0; c < C; ++c) xx[at(i) * C + std::size_t(c)] += px[c];
                    }
                }, kRowGrain);
                break;
            }
        }
    }
};

/// Spectral radius of D^-1 A: 20 power iterations from a fixed pseudo-random vector, times
/// 1.1, capped by the Gershgorin bound max_i sum_j |a_ij| / a_ii (always an upper bound).
Real spectralRadius(const SparseRows& A, const std::vector<Real>& invDiag) {
    const Index n = A.rows;
    Real gershgorin = 0;
    for (Index i = 0; i < n; ++i) {
        Real s = 0;
        for (int k = A.start[at(i)]; k < A.start[at(i) + 1]; ++k) s += std::abs(A.value[static_cast<std::size_t>(k)]);
        gershgorin = std::max(gershgorin, s * invDiag[at(i)]);
    }
    std::vector<Real> v(at(n)), w(at(n));
    for (Index i = 0; i < n; ++i) {
        std::uint64_t h = std::uint64_t(i) * 0x9E3779B97F4A7C15ull;
        h ^= h >> 29;
        v[at(i)] = Real((h >> 11) & 0xFFFF) / Real(0xFFFF) - Real(0.5);
    }
    Real estimate = 0;
    for (int it = 0; it < 20; ++it) {
        multiply(A, v.data(), w.data(), 1);
        Real nv = 0, nw = 0;
        for (Index i = 0; i < n; ++i) {
            w[at(i)] *= invDiag[at(i)];
            nv += v[at(i)] * v[at(i)];
            nw += w[at(i)] * w[at(i)];
        }
        if (!(nw > 0) || !(nv > 0)) break;
        estimate = std::sqrt(nw / nv);
        const Real inv = Real(1) / std::sqrt(nw);
        for (Index i = 0; i < n; ++i) v[at(i)] = w[at(i)] * inv;
    }
    return std::min(gershgorin, Real(1.1) * estimate > 0 ? Real(1.1) * estimate : gershgorin);
}

/// q = A p and the column dots p.q in one pass (fixed 4096-row blocks, as columnDots).
template <int C>
Sums multiplyDotFixed(const SparseRows& A, const Real* p, Real* q) {
    const int* st = A.start.data();
    const int* col = A.column.data();
    const Real* val = A.value.data();
    return parallelReduce(
        A.rows, Sums{0, 0, 0, 0},
        [&](Sums& s, Index i) {
            Real acc[C];
            rowTimes<C, Real>(st, col, val, i, p, acc);
            for (int c = 0; c < C; ++c) {
                const std::size_t k = at(i) * C + std::size_t(c);
                q[k] = acc[c];
                s[std::size_t(c)] += p[k] * q[k];
            }
        },
        combineSums<C>, 4096);
}

/// X += alpha P, R -= alpha Q and the column dots R.R in one pass.
template <int C>
Sums updateDotFixed(Index n, Real* X, Real* R, const Real* P, const Real* Q, const Sums& alpha) {
    return parallelReduce(
        n, Sums{0, 0, 0, 0},
        [&](Sums& s, Index i) {
            for (int c = 0; c < C; ++c) {
                const std::size_t k = at(i) * C + std::size_t(c);
                X[k] += alpha[std::size_t(c)] * P[k];
                R[k] -= alpha[std::size_t(c)] * Q[k];
                s[std::size_t(c)] += R[k] * R[k];
            }
        },
        combineSums<C>, 4096);
}

Sums multiplyDot(const SparseRows& A, const Real* p, Real* q, int cols) {
    switch (cols) {
        case 1: return multiplyDotFixed<1>(A, p, q);
        case 2: return multiplyDotFixed<2>(A, p, q);
        case 3: return multiplyDotFixed<3>(A, p, q);
        default: return multiplyDotFixed<4>(A, p, q);
    }
}

Sums updateDot(Index n, Real* X, Real* R, const Real* P, const Real* Q, const Sums& alpha, int cols) {
    switch (cols) {
        case 1: return updateDotFixed<1>(n, X, R, P, Q, alpha);
        case 2: return updateDotFixed<2>(n, X, R, P, Q, alpha);
        case 3: return updateDotFixed<3>(n, X, R, P, Q, alpha);
        default: return updateDotFixed<4>(n, X, R, P, Q, alpha);
    }
}

}  // namespace

void multiply(const SparseRows& A, const Real* x, Real* y, int cols) {
    DGV_CHECK(cols >= 1 && cols <= kMaxCols);
    multiplyRows(A.start, A.column, A.value, A.rows, x, y, cols);
}

struct AggregationMultigrid::Impl {
    MultigridSettings settings;
    std::vector<Level> levels;
    Eigen::LDLT<Eigen::MatrixXd> coarsest;
    mutable std::vector<std::vector<Real>> rhs, sol;  ///< per level b and x
    double seconds = 0;

    /// Chebyshev smoothing of level l on x (zero: x starts at 0), fused passes (SmoothPasses).
    void smooth(const Level& L, const Real* b, Real* x, int cols, bool zero) const {
        const std::size_t n = at(L.A.rows) * std::size_t(cols);
        L.r.resize(n);
        L.d.resize(n);
        L.d2.resize(n);
        L.t.resize(n);
        SmoothPasses f{L, cols, b, x};
        f.degree = settings.smootherDegree;
        f.theta = Real(0.5) * (L.lmax + L.lmin);
        f.delta = Real(0.5) * (L.lmax - L.lmin);
        f.sigma = f.theta / f.delta;
        f.kind = zero ? SmoothPasses::Kind::Pre : SmoothPasses::Kind::Post;
        dispatch(L, cols, f);
    }

    void cycle(std::size_t l, const Real* b, Real* x, int cols) const {
        const Level& L = levels[l];
        if (l + 1 == levels.size()) {
            Eigen::MatrixXd rhsM(L.A.rows, cols);
            for (Index i = 0; i < L.A.rows; ++i)
                for (int c = 0; c < cols; ++c) rhsM(i, c) = b[at(i) * std::size_t(cols) + std::size_t(c)];
            const Eigen::MatrixXd s = coarsest.solve(rhsM);
            for (Index i = 0; i < L.A.rows; ++i)
                for (int c = 0; c < cols; ++c) x[at(i) * std::size_t(cols) + std::size_t(c)] = s(i, c);
            return;
        }
        smooth(L, b, x, cols, true);
        // residual into L.t, restricted into the next level's right-hand side
        SmoothPasses res{L, cols, b, x};
        res.kind = SmoothPasses::Kind::Residual;
        dispatch(L, cols, res);
        const Level& C = levels[l + 1];
        std::vector<Real>& bc = rhs[l + 1];
        std::vector<Real>& xc = sol[l + 1];
        bc.resize(at(C.A.rows) * std::size_t(cols));
        xc.resize(bc.size());
        multiplyRows(L.R.start, L.R.column, L.R.value, L.R.rows, L.t.data(), bc.data(), cols);
        cycle(l + 1, bc.data(), xc.data(), cols);
        SmoothPasses pro{L, cols, b, x};
        pro.kind = SmoothPasses::Kind::Prolong;
        pro.xc = xc.data();
        dispatch(L, cols, pro);
        smooth(L, b, x, cols, false);
    }
};

AggregationMultigrid::AggregationMultigrid(const SparseRows& A, const std::vector<Vec3i>& coords,
                                           const MultigridSettings& settings)
    : mImpl(std::make_unique<Impl>()) {
    const auto start = std::chrono::steady_clock::now();
    DGV_CHECK_EQ(static_cast<Index>(coords.size()), A.rows);
    DGV_CHECK(settings.aggregateSize >= 2);
    Impl& m = *mImpl;
    m.settings = settings;
    SparseRows current = A;
    std::vector<Vec3i> xyz = coords;
    for (int level = 0;; ++level) {
        Level L;
        L.A = std::move(current);
        const Index n = L.A.rows;
        L.invDiag.assign(at(n), 0);
        for (Index i = 0; i < n; ++i)
            for (int k = L.A.start[at(i)]; k < L.A.start[at(i) + 1]; ++k)
                if (L.A.column[static_cast<std::size_t>(k)] == i) L.invDiag[at(i)] = Real(1) / L.A.value[static_cast<std::size_t>(k)];
        for (Index i = 0; i < n; ++i) DGV_CHECK(L.invDiag[at(i)] > 0);
        if (std::all_of(L.A.value.begin(), L.A.value.end(),
                        [](Real v) { return Real(static_cast<float>(v)) == v; }))
            L.valueF.assign(L.A.value.begin(), L.A.value.end());
        const Real rho = spectralRadius(L.A, L.invDiag);
        L.lmax = rho;
        L.lmin = rho / settings.eigenRatio;
        const bool last = n <= settings.coarsestRows || level + 1 >= settings.maxLevels;
        if (!last) {
            // Aggregates: sites in the same block of aggregateSize^3, in order of first row.
            std::map<std::array<int, 3>, int> ids;
            std::vector<int> agg(at(n));
            std::vector<Vec3i> coarseXyz;
            for (Index i = 0; i < n; ++i) {
                const Vec3i& v = xyz[at(i)];
                Vec3i c = v / settings.aggregateSize;
                if (settings.parityAggregates)
                    for (int a = 0; a < 3; ++a) c[a] = 2 * ((v[a] >> 1) / settings.aggregateSize) + (v[a] & 1);
                const auto [it, inserted] = ids.try_emplace({c.x(), c.y(), c.z()}, int(coarseXyz.size()));
                if (inserted) coarseXyz.push_back(c);
                agg[at(i)] = it->second;
            }
            const Index nc = static_cast<Index>(coarseXyz.size());
            if (nc < n) {
                SpMat Pt(n, nc);
                std::vector<Eigen::Triplet<Real, int>> t;
                t.reserve(at(n));
                for (Index i = 0; i < n; ++i) t.emplace_back(int(i), agg[at(i)], Real(1));
                Pt.setFromTriplets(t.begin(), t.end());
                const SpMat Ae = toEigen(L.A);
                Eigen::VectorXd dinv(n);
                for (Index i = 0; i < n; ++i) dinv[i] = L.invDiag[at(i)];
                const Real omega = Real(4) / Real(3) / rho;
                const SpMat APt = Ae * Pt;
                const SpMat P = Pt - SpMat((omega * dinv).asDiagonal() * APt);
                const SpMat AP = Ae * P;
                const SpMat R = SpMat(P.transpose());
                const SpMat Ac = R * AP;
                L.P = fromEigen(P);
                L.R = fromEigen(R);
                current = fromEigen(Ac);
                xyz = std::move(coarseXyz);
                m.levels.push_back(std::move(L));
                continue;
            }
        }
        // coarsest level: dense LDL^T
        Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
        for (Index i = 0; i < n; ++i)
            for (int k = L.A.start[at(i)]; k < L.A.start[at(i) + 1]; ++k)
                dense(i, L.A.column[static_cast<std::size_t>(k)]) = L.A.value[static_cast<std::size_t>(k)];
        m.coarsest.compute(dense);
        m.levels.push_back(std::move(L));
        break;
    }
    m.rhs.resize(m.levels.size());
    m.sol.resize(m.levels.size());
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

AggregationMultigrid::~AggregationMultigrid() = default;

void AggregationMultigrid::apply(const Real* r, Real* z, int cols) const {
    DGV_CHECK(cols >= 1 && cols <= kMaxCols);
    mImpl->cycle(0, r, z, cols);
}

const SparseRows& AggregationMultigrid::matrix() const { return mImpl->levels.front().A; }
int AggregationMultigrid::levels() const { return static_cast<int>(mImpl->levels.size()); }
Index AggregationMultigrid::rowsAt(int level) const { return mImpl->levels[static_cast<std::size_t>(level)].A.rows; }
double AggregationMultigrid::setupSeconds() const { return mImpl->seconds; }

SolveReport conjugateGradients(const SparseRows& A, const AggregationMultigrid* mg,
                               const std::vector<Real>& B, std::vector<Real>& X, int cols,
                               Real tolerance, Real scale, int maxIterations,
                               CgWorkspace* workspace) {
    const auto start = std::chrono::steady_clock::now();
    DGV_CHECK(cols >= 1 && cols <= kMaxCols);
    const Index n = A.rows;
    const std::size_t len = at(n) * std::size_t(cols);
    DGV_CHECK_EQ(B.size(), len);
    DGV_CHECK_EQ(X.size(), len);
    CgWorkspace local;
    CgWorkspace& w = workspace ? *workspace : local;
    w.r.resize(len);
    w.z.resize(len);
    w.p.resize(len);
    w.q.resize(len);
    std::vector<Real>& R = w.r;
    std::vector<Real>& Z = w.z;
    std::vector<Real>& P = w.p;
    std::vector<Real>& Q = w.q;
    std::vector<Real> invDiag;
    if (!mg) {
        invDiag.assign(at(n), 0);
        for (Index i = 0; i < n; ++i)
            for (int k = A.start[at(i)]; k < A.start[at(i) + 1]; ++k)
                if (A.column[static_cast<std::size_t>(k)] == i) invDiag[at(i)] = Real(1) / A.value[static_cast<std::size_t>(k)];
    }
    auto precondition = [&](const std::vector<Real>& r, std::vector<Real>& z) {
        if (mg) {
            mg->apply(r.data(), z.data(), cols);
        } else {
            parallelFor(Index(len), [&](Index k) { z[at(k)] = invDiag[at(k) / std::size_t(cols)] * r[at(k)]; }, 4 * kRowGrain);
        }
    };
    auto total = [&](const Sums& s) {
        Real t = 0;
        for (int c = 0; c < cols; ++c) t += s[std::size_t(c)];
        return t;
    };
    multiply(A, X.data(), Q.data(), cols);
    parallelFor(Index(len), [&](Index k) { R[at(k)] = B[at(k)] - Q[at(k)]; }, 4 * kRowGrain);
    if (!(scale > 0)) scale = std::sqrt(total(columnDots(B.data(), B.data(), n, cols)));
    if (!(scale > 0)) scale = 1;
    SolveReport report;
    report.residual = std::sqrt(total(columnDots(R.data(), R.data(), n, cols))) / scale;
    report.converged = report.residual <= tolerance;
    if (report.converged) {
        report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return report;
    }
    precondition(R, Z);
    P = Z;
    Sums rz = columnDots(R.data(), Z.data(), n, cols);
    for (int it = 1; it <= maxIterations; ++it) {
        // fused passes: q = A p with p.q, then the updates of X and R with R.R (the same sums,
        // in the same order, as separate loops and columnDots)
        const Sums pq = multiplyDot(A, P.data(), Q.data(), cols);
        Sums alpha{0, 0, 0, 0};
        for (int c = 0; c < cols; ++c)
            alpha[std::size_t(c)] = pq[std::size_t(c)] > 0 ? rz[std::size_t(c)] / pq[std::size_t(c)] : Real(0);
        const Sums rr = updateDot(n, X.data(), R.data(), P.data(), Q.data(), alpha, cols);
        report.iterations = it;
        report.residual = std::sqrt(total(rr)) / scale;
        if (!std::isfinite(report.residual)) {
            report.diverged = true;
            break;
        }
        if (report.residual <= tolerance) {
            report.converged = true;
            break;
        }
        precondition(R, Z);
        const Sums rzNew = columnDots(R.data(), Z.data(), n, cols);
        Sums beta{0, 0, 0, 0};
        for (int c = 0; c < cols; ++c)
            beta[std::size_t(c)] = rz[std::size_t(c)] > 0 ? rzNew[std::size_t(c)] / rz[std::size_t(c)] : Real(0);
        rz = rzNew;
        parallelFor(n, [&](Index i) {
            for (int c = 0; c < cols; ++c) {
                const std::size_t k = at(i) * std::size_t(cols) + std::size_t(c);
                P[k] = Z[k] + beta[std::size_t(c)] * P[k];
            }
        }, kRowGrain);
    }
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

}  // namespace dgv
