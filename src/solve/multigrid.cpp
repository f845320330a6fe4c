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
void multiplyRowsFixed(const int* start, const int* column, const Real* value, Index rows, const Real* x, Real* y) {
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
void multiplyRows(const std::vector<int>& start, const std::vector<int>& column, const std::vector<Real>& value,
                  Index rows, const Real* x, Real* y, int cols) {
    switch (cols) {
        case 1:
            multiplyRowsFixed<1>(start.data(), column.data(), value.data(), rows, x, y);
            break;
        case 2:
            multiplyRowsFixed<2>(start.data(), column.data(), value.data(), rows, x, y);
            break;
        case 3:
            multiplyRowsFixed<3>(start.data(), column.data(), value.data(), rows, x, y);
            break;
        default:
            multiplyRowsFixed<4>(start.data(), column.data(), value.data(), rows, x, y);
            break;
    }
}

using Sums = std::array<Real, kMaxCols>;

/// Per-column dot products of two rows x cols arrays (deterministic).
Sums columnDots(const Real* a, const Real* b, Index rows, int cols) {
    return parallelReduce(
        rows, Sums{0, 0, 0, 0},
        [&](Sums& s, Index i) {
            for (int c = 0; c < cols; ++c)
                s[std::size_t(c)] +=
                    a[at(i) * std::size_t(cols) + std::size_t(c)] * b[at(i) * std::size_t(cols) + std::size_t(c)];
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

/// Work arrays of one level in the scalar type T of the V-cycle (rows x cols).
template <typename T>
struct Work {
    std::vector<T> r, d, d2, t;
    void resize(std::size_t n) {
        r.resize(n);
        d.resize(n);
        d2.resize(n);
        t.resize(n);
    }
};

struct Level {
    SparseRows A;
    std::vector<Real> invDiag;
    Real lmin = 0, lmax = 0;
    SparseRows P;  ///< prolongation to this level from the next coarser one: rows = A.rows
    SparseRows R;  ///< P^T: rows = coarse rows
    /// A's values as floats when every one of them is exactly a float (the lattice Laplacian:
    /// small integers), else empty: the same products from half the value bytes.
    std::vector<float> valueF;
    /// Every off-diagonal value is exactly -1 (the graph Laplacian): rows are products with the
    /// diagonal and the columns only (UnitRows), the same operations without the value array.
    bool unit = false;
    std::vector<Real> diag;
    /// The float V-cycle (MultigridSettings::floatCycle): A, D^-1, P and R rounded to float.
    std::vector<float> valueR, invDiagR, diagR, pValueR, rValueR;
    mutable Work<Real> wd;
    mutable Work<float> wf;
    template <typename T>
    Work<T>& work() const {
        if constexpr (std::is_same_v<T, float>)
            return wf;
        else
            return wd;
    }
    template <typename T>
    const T* invD() const {
        if constexpr (std::is_same_v<T, float>)
            return invDiagR.data();
        else
            return invDiag.data();
    }
};

/// Row products acc = row i of M times x (C interleaved columns), entries in column order,
/// accumulated in T: the same floating-point operations as multiplyRowsFixed. V: the stored
/// value type (float only where exact, or in the float V-cycle).
template <typename V>
struct ValuedRows {
    const int* start;
    const int* column;
    const V* value;
    template <int C, typename T>
    inline void row(Index i, const T* x, T* acc) const {
        for (int c = 0; c < C; ++c) acc[c] = 0;
        const int end = start[i + 1];
        for (int k = start[i]; k < end; ++k) {
            const T v = T(value[k]);
            const T* xr = x + std::ptrdiff_t(column[k]) * C;
            for (int c = 0; c < C; ++c) acc[c] += v * xr[c];
        }
    }
};

/// Rows whose off-diagonal values are all exactly -1: acc += (-1) x is exactly acc - x, so these
/// are the operations of ValuedRows, bit for bit, without reading a value per entry.
template <typename D>
struct UnitRows {
    const int* start;
    const int* column;
    const D* diag;
    template <int C, typename T>
    inline void row(Index i, const T* x, T* acc) const {
        for (int c = 0; c < C; ++c) acc[c] = 0;
        const int end = start[i + 1];
        for (int k = start[i]; k < end; ++k) {
            const int j = column[k];
            const T* xr = x + std::ptrdiff_t(j) * C;
            if (j == i) {
                const T v = T(diag[i]);
                for (int c = 0; c < C; ++c) acc[c] += v * xr[c];
            } else {
                for (int c = 0; c < C; ++c) acc[c] -= xr[c];
            }
        }
    }
};

/// Calls f.template run<C>(rows) with the column count and the row products of level L's matrix
/// for a V-cycle in T.
template <typename T, typename F>
void dispatch(const Level& L, int cols, F&& f) {
    auto go = [&](const auto& rows) {
        switch (cols) {
            case 1:
                f.template run<1>(rows);
                break;
            case 2:
                f.template run<2>(rows);
                break;
            case 3:
                f.template run<3>(rows);
                break;
            default:
                f.template run<4>(rows);
                break;
        }
    };
    const int* st = L.A.start.data();
    const int* col = L.A.column.data();
    if constexpr (std::is_same_v<T, float>) {
        if (L.unit)
            go(UnitRows<float>{st, col, L.diagR.data()});
        else
            go(ValuedRows<float>{st, col, L.valueR.data()});
    } else {
        if (L.unit)
            go(UnitRows<Real>{st, col, L.diag.data()});
        else if (!L.valueF.empty())
            go(ValuedRows<float>{st, col, L.valueF.data()});
        else
            go(ValuedRows<Real>{st, col, L.A.value.data()});
    }
}

/// The fused passes of the V-cycle on one level, in T (Real, or float for the float V-cycle).
/// Each computes exactly the operations of the unfused sequence (multiply into t, then the
/// vector updates), row by row, so the results are bit-identical to it; a pass never writes an
/// array whose other rows it reads.
template <typename T>
struct SmoothPasses {
    const Level& L;
    int cols;
    const T* b;
    T* x;
    const T* xc = nullptr;  ///< coarse correction (prolongation pass)
    int degree = 2;
    T theta = 0, sigma = 0, delta = 0;
    enum class Kind { Pre, Post, Residual, Prolong } kind = Kind::Pre;

    /// Chebyshev steps 1..degree after d (step 0) is set in the level's d; x already holds the
    /// start (or is assigned on the first step when `zero`).
    template <int C, typename Rows>
    void chebyshev(const Rows& rows, bool zero) {
        Work<T>& w = L.work<T>();
        const T* invDiag = L.invD<T>();
        T rho = T(1) / sigma;
        T* d = w.d.data();
        T* dn = w.d2.data();
        T* r = w.r.data();
        bool first = true;  // x not yet touched by any step
        for (int step = 1; step <= degree; ++step) {
            if (step == degree) {
                // x += d (x = d for a zero start with degree 1)
                T* xx = x;
                const bool assign = zero && first;
                parallelForBlocks(
                    L.A.rows,
                    [&](Index b0, Index e0) {
                        for (std::size_t k = at(b0) * C; k < at(e0) * C; ++k) xx[k] = assign ? d[k] : xx[k] + d[k];
                    },
                    kRowGrain);
                break;
            }
            const T rhoNew = T(1) / (2 * sigma - rho);
            const T c1 = rhoNew * rho, c2 = 2 * rhoNew / delta;
            const bool assign = zero && first;
            const bool last = step + 1 == degree;
            T* xx = x;
            parallelForBlocks(
                L.A.rows,
                [&](Index b0, Index e0) {
                    for (Index i = b0; i < e0; ++i) {
                        T t[C];
                        rows.template row<C, T>(i, d, t);
                        for (int c = 0; c < C; ++c) {
                            const std::size_t k = at(i) * C + std::size_t(c);
                            const T rk = r[k] - invDiag[i] * t[c];
                            const T dk = c1 * d[k] + c2 * rk;
                            T xk = assign ? d[k] : xx[k] + d[k];
                            if (last) {
                                xx[k] = xk + dk;  // r and d are not needed after the last step
                            } else {
                                xx[k] = xk;
                                r[k] = rk;
                                dn[k] = dk;
                            }
                        }
                    }
                },
                kRowGrain);
            std::swap(d, dn);
            rho = rhoNew;
            first = false;
            if (last) break;
        }
    }

    template <int C, typename Rows>
    void run(const Rows& rows) {
        Work<T>& w = L.work<T>();
        const T* invDiag = L.invD<T>();
        T* r = w.r.data();
        T* d = w.d.data();
        T* t = w.t.data();
        const T* bb = b;
        T* xx = x;
        switch (kind) {
            case Kind::Pre:
                parallelForBlocks(
                    L.A.rows,
                    [&](Index b0, Index e0) {
                        for (Index i = b0; i < e0; ++i)
                            for (int c = 0; c < C; ++c) {
                                const std::size_t k = at(i) * C + std::size_t(c);
                                r[k] = invDiag[i] * (bb[k] - T(0));
                                d[k] = r[k] / theta;
                            }
                    },
                    kRowGrain);
                chebyshev<C>(rows, true);
                break;
            case Kind::Post:
                parallelForBlocks(
                    L.A.rows,
                    [&](Index b0, Index e0) {
                        for (Index i = b0; i < e0; ++i) {
                            T ax[C];
                            rows.template row<C, T>(i, xx, ax);
                            for (int c = 0; c < C; ++c) {
                                const std::size_t k = at(i) * C + std::size_t(c);
                                r[k] = invDiag[i] * (bb[k] - ax[c]);
                                d[k] = r[k] / theta;
                            }
                        }
                    },
                    kRowGrain);
                chebyshev<C>(rows, false);
                break;
            case Kind::Residual:
                parallelForBlocks(
                    L.A.rows,
                    [&](Index b0, Index e0) {
                        for (Index i = b0; i < e0; ++i) {
                            T ax[C];
                            rows.template row<C, T>(i, xx, ax);
                            for (int c = 0; c < C; ++c)
                                t[at(i) * C + std::size_t(c)] = bb[at(i) * C + std::size_t(c)] - ax[c];
                        }
                    },
                    kRowGrain);
                break;
            case Kind::Prolong: {
                const T* cc = xc;
                auto prolong = [&](const auto& p) {
                    parallelForBlocks(
                        L.P.rows,
                        [&](Index b0, Index e0) {
                            for (Index i = b0; i < e0; ++i) {
                                T px[C];
                                p.template row<C, T>(i, cc, px);
                                for (int c = 0; c < C; ++c) xx[at(i) * C + std::size_t(c)] += px[c];
                            }
                        },
                        kRowGrain);
                };
                if constexpr (std::is_same_v<T, float>)
                    prolong(ValuedRows<float>{L.P.start.data(), L.P.column.data(), L.pValueR.data()});
                else
                    prolong(ValuedRows<Real>{L.P.start.data(), L.P.column.data(), L.P.value.data()});
                break;
            }
        }
    }
};

/// Rectangular y = M x (M by rows, `rows` row products), C interleaved columns, in T.
template <int C, typename T, typename Rows>
void multiplyRowsWith(const Rows& m, Index n, const T* x, T* y) {
    parallelForBlocks(
        n,
        [&](Index b, Index e) {
            for (Index i = b; i < e; ++i) {
                T acc[C];
                m.template row<C, T>(i, x, acc);
                for (int c = 0; c < C; ++c) y[at(i) * C + std::size_t(c)] = acc[c];
            }
        },
        kRowGrain);
}

/// The restriction b_c = R t of level L in T.
template <typename T>
void restrictTo(const Level& L, const T* t, T* bc, int cols) {
    auto go = [&](const auto& rows) {
        switch (cols) {
            case 1:
                multiplyRowsWith<1>(rows, L.R.rows, t, bc);
                break;
            case 2:
                multiplyRowsWith<2>(rows, L.R.rows, t, bc);
                break;
            case 3:
                multiplyRowsWith<3>(rows, L.R.rows, t, bc);
                break;
            default:
                multiplyRowsWith<4>(rows, L.R.rows, t, bc);
                break;
        }
    };
    if constexpr (std::is_same_v<T, float>)
        go(ValuedRows<float>{L.R.start.data(), L.R.column.data(), L.rValueR.data()});
    else
        go(ValuedRows<Real>{L.R.start.data(), L.R.column.data(), L.R.value.data()});
}

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
template <int C, typename Rows>
Sums multiplyDotFixed(const Rows& rows, Index n, const Real* p, Real* q) {
    return parallelReduce(
        n, Sums{0, 0, 0, 0},
        [&](Sums& s, Index i) {
            Real acc[C];
            rows.template row<C, Real>(i, p, acc);
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

/// q = A p with p.q; `fine`: the multigrid level whose matrix A is (its row products), or null.
Sums multiplyDot(const SparseRows& A, const Level* fine, const Real* p, Real* q, int cols) {
    auto go = [&](const auto& rows) {
        switch (cols) {
            case 1:
                return multiplyDotFixed<1>(rows, A.rows, p, q);
            case 2:
                return multiplyDotFixed<2>(rows, A.rows, p, q);
            case 3:
                return multiplyDotFixed<3>(rows, A.rows, p, q);
            default:
                return multiplyDotFixed<4>(rows, A.rows, p, q);
        }
    };
    if (fine && fine->unit) return go(UnitRows<Real>{A.start.data(), A.column.data(), fine->diag.data()});
    if (fine && !fine->valueF.empty())
        return go(ValuedRows<float>{A.start.data(), A.column.data(), fine->valueF.data()});
    return go(ValuedRows<Real>{A.start.data(), A.column.data(), A.value.data()});
}

Sums updateDot(Index n, Real* X, Real* R, const Real* P, const Real* Q, const Sums& alpha, int cols) {
    switch (cols) {
        case 1:
            return updateDotFixed<1>(n, X, R, P, Q, alpha);
        case 2:
            return updateDotFixed<2>(n, X, R, P, Q, alpha);
        case 3:
            return updateDotFixed<3>(n, X, R, P, Q, alpha);
        default:
            return updateDotFixed<4>(n, X, R, P, Q, alpha);
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
    mutable std::vector<std::vector<Real>> rhs, sol;     ///< per level b and x
    mutable std::vector<std::vector<float>> rhsF, solF;  ///< the same for the float V-cycle
    double seconds = 0;

    template <typename T>
    std::vector<std::vector<T>>& rhsOf() const {
        if constexpr (std::is_same_v<T, float>)
            return rhsF;
        else
            return rhs;
    }
    template <typename T>
    std::vector<std::vector<T>>& solOf() const {
        if constexpr (std::is_same_v<T, float>)
            return solF;
        else
            return sol;
    }

    /// Chebyshev smoothing of level l on x (zero: x starts at 0), fused passes (SmoothPasses).
    template <typename T>
    void smooth(const Level& L, const T* b, T* x, int cols, bool zero) const {
        L.work<T>().resize(at(L.A.rows) * std::size_t(cols));
        SmoothPasses<T> f{L, cols, b, x};
        f.degree = settings.smootherDegree;
        const Real theta = Real(0.5) * (L.lmax + L.lmin), delta = Real(0.5) * (L.lmax - L.lmin);
        f.theta = T(theta);
        f.delta = T(delta);
        f.sigma = T(theta / delta);
        f.kind = zero ? SmoothPasses<T>::Kind::Pre : SmoothPasses<T>::Kind::Post;
        dispatch<T>(L, cols, f);
    }

    template <typename T>
    void cycle(std::size_t l, const T* b, T* x, int cols) const {
        const Level& L = levels[l];
        if (l + 1 == levels.size()) {
            Eigen::MatrixXd rhsM(L.A.rows, cols);
            for (Index i = 0; i < L.A.rows; ++i)
                for (int c = 0; c < cols; ++c) rhsM(i, c) = Real(b[at(i) * std::size_t(cols) + std::size_t(c)]);
            const Eigen::MatrixXd s = coarsest.solve(rhsM);
            for (Index i = 0; i < L.A.rows; ++i)
                for (int c = 0; c < cols; ++c) x[at(i) * std::size_t(cols) + std::size_t(c)] = T(s(i, c));
            return;
        }
        smooth<T>(L, b, x, cols, true);
        // residual into the level's t, restricted into the next level's right-hand side
        SmoothPasses<T> res{L, cols, b, x};
        res.kind = SmoothPasses<T>::Kind::Residual;
        dispatch<T>(L, cols, res);
        const Level& C = levels[l + 1];
        std::vector<T>& bc = rhsOf<T>()[l + 1];
        std::vector<T>& xc = solOf<T>()[l + 1];
        bc.resize(at(C.A.rows) * std::size_t(cols));
        xc.resize(bc.size());
        restrictTo<T>(L, L.work<T>().t.data(), bc.data(), cols);
        cycle<T>(l + 1, bc.data(), xc.data(), cols);
        SmoothPasses<T> pro{L, cols, b, x};
        pro.kind = SmoothPasses<T>::Kind::Prolong;
        pro.xc = xc.data();
        dispatch<T>(L, cols, pro);
        smooth<T>(L, b, x, cols, false);
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
                if (L.A.column[static_cast<std::size_t>(k)] == i)
                    L.invDiag[at(i)] = Real(1) / L.A.value[static_cast<std::size_t>(k)];
        for (Index i = 0; i < n; ++i) DGV_CHECK(L.invDiag[at(i)] > 0);
        if (std::all_of(L.A.value.begin(), L.A.value.end(), [](Real v) { return Real(static_cast<float>(v)) == v; }))
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
    for (Level& L : m.levels) {
        // unit rows: every off-diagonal value exactly -1 (the lattice graph Laplacian)
        L.diag.assign(at(L.A.rows), 0);
        L.unit = true;
        for (Index i = 0; i < L.A.rows; ++i)
            for (int k = L.A.start[at(i)]; k < L.A.start[at(i) + 1]; ++k) {
                const Real v = L.A.value[static_cast<std::size_t>(k)];
                if (L.A.column[static_cast<std::size_t>(k)] == i)
                    L.diag[at(i)] = v;
                else if (v != Real(-1))
                    L.unit = false;
            }
        if (L.unit)
            L.valueF.clear();  // unit rows read no values
        else
            L.diag.clear();
        if (settings.floatCycle) {
            auto toFloat = [](const std::vector<Real>& v) { return std::vector<float>(v.begin(), v.end()); };
            if (!L.unit) L.valueR = toFloat(L.A.value);
            L.diagR = toFloat(L.diag);
            L.invDiagR = toFloat(L.invDiag);
            L.pValueR = toFloat(L.P.value);
            L.rValueR = toFloat(L.R.value);
        }
    }
    m.rhs.resize(m.levels.size());
    m.sol.resize(m.levels.size());
    m.rhsF.resize(m.levels.size());
    m.solF.resize(m.levels.size());
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

AggregationMultigrid::~AggregationMultigrid() = default;

void AggregationMultigrid::apply(const Real* r, Real* z, int cols) const {
    DGV_CHECK(cols >= 1 && cols <= kMaxCols);
    const Impl& m = *mImpl;
    if (!m.settings.floatCycle) {
        m.cycle<Real>(0, r, z, cols);
        return;
    }
    // float V-cycle: r rounded to float, the cycle in float, z widened back. The cycle runs on
    // kMaxCols (4) columns, the unused ones zero (they stay zero: every operation is linear):
    // each row of 4 floats is one 16-byte vector, so the row products vectorise.
    const Index rows = m.levels.front().A.rows;
    const std::size_t len = at(rows) * kMaxCols;
    std::vector<float>& b = m.rhsF[0];
    std::vector<float>& x = m.solF[0];
    b.resize(len);
    x.resize(len);
    parallelForBlocks(
        rows,
        [&](Index b0, Index e0) {
            for (Index i = b0; i < e0; ++i)
                for (int c = 0; c < kMaxCols; ++c)
                    b[at(i) * kMaxCols + std::size_t(c)] =
                        c < cols ? float(r[at(i) * std::size_t(cols) + std::size_t(c)]) : 0.0f;
        },
        kRowGrain);
    m.cycle<float>(0, b.data(), x.data(), kMaxCols);
    parallelForBlocks(
        rows,
        [&](Index b0, Index e0) {
            for (Index i = b0; i < e0; ++i)
                for (int c = 0; c < cols; ++c)
                    z[at(i) * std::size_t(cols) + std::size_t(c)] = Real(x[at(i) * kMaxCols + std::size_t(c)]);
        },
        kRowGrain);
}

const SparseRows& AggregationMultigrid::matrix() const { return mImpl->levels.front().A; }
int AggregationMultigrid::levels() const { return static_cast<int>(mImpl->levels.size()); }
Index AggregationMultigrid::rowsAt(int level) const { return mImpl->levels[static_cast<std::size_t>(level)].A.rows; }
double AggregationMultigrid::setupSeconds() const { return mImpl->seconds; }

SolveReport conjugateGradients(const SparseRows& A, const AggregationMultigrid* mg, const std::vector<Real>& B,
                               std::vector<Real>& X, int cols, Real tolerance, Real scale, int maxIterations,
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
    // A is the multigrid's own matrix: its row products (unit rows, float values) serve here too
    const Level* fine = mg && &A == &mg->matrix() ? &mg->mImpl->levels.front() : nullptr;
    std::vector<Real> invDiag;
    if (!mg) {
        invDiag.assign(at(n), 0);
        for (Index i = 0; i < n; ++i)
            for (int k = A.start[at(i)]; k < A.start[at(i) + 1]; ++k)
                if (A.column[static_cast<std::size_t>(k)] == i)
                    invDiag[at(i)] = Real(1) / A.value[static_cast<std::size_t>(k)];
    }
    auto precondition = [&](const std::vector<Real>& r, std::vector<Real>& z) {
        if (mg) {
            mg->apply(r.data(), z.data(), cols);
        } else {
            parallelFor(
                Index(len), [&](Index k) { z[at(k)] = invDiag[at(k) / std::size_t(cols)] * r[at(k)]; }, 4 * kRowGrain);
        }
    };
    auto total = [&](const Sums& s) {
        Real t = 0;
        for (int c = 0; c < cols; ++c) t += s[std::size_t(c)];
        return t;
    };
    (void)multiplyDot(A, fine, X.data(), Q.data(), cols);
    parallelFor(
        Index(len), [&](Index k) { R[at(k)] = B[at(k)] - Q[at(k)]; }, 4 * kRowGrain);
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
        const Sums pq = multiplyDot(A, fine, P.data(), Q.data(), cols);
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
        parallelFor(
            n,
            [&](Index i) {
                for (int c = 0; c < cols; ++c) {
                    const std::size_t k = at(i) * std::size_t(cols) + std::size_t(c);
                    P[k] = Z[k] + beta[std::size_t(c)] * P[k];
                }
            },
            kRowGrain);
    }
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

}  // namespace dgv
