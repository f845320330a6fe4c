#include "dynamics/forces.hpp"

#include "base/errors.hpp"
#include "base/parallel.hpp"

#include <cmath>
#include <sstream>

namespace dgv {
namespace {

constexpr Real kTwoPi = 6.283185307179586476925286766559;

std::string got(Real v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

bool finite(const Vec3& v) { return v.allFinite(); }

/// splitmix64: a small, well-mixed, platform-independent generator (the noise must not depend
/// on the standard library's distributions, which differ between implementations).
class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : mState(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (mState += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    /// Uniform in [0, 1), 53 bits.
    Real uniform() { return static_cast<Real>(next() >> 11) * 0x1.0p-53; }

private:
    std::uint64_t mState;
};

/// Adds a radial field F = f(q) d, q = |d|², given f, f' = df/dq and f'' at q:
///   ∂F_i/∂x_j = f δ_ij + 2 f' d_i d_j
///   ∂²F_i/∂x_j∂x_k = 2 f' (δ_ij d_k + δ_ik d_j + δ_jk d_i) + 4 f'' d_i d_j d_k.
void addRadial(const Vec3& d, Real f, Real f1, Real f2, ForceOrder order, ForceSample& out) {
    out.value += f * d;
    if (order == ForceOrder::Value) return;
    out.gradient += f * Mat3::Identity() + (2 * f1) * d * d.transpose();
    if (order == ForceOrder::Gradient) return;
    for (int i = 0; i < 3; ++i) {
        Mat3 h = (4 * f2 * d[i]) * d * d.transpose();
        h += (2 * f1 * d[i]) * Mat3::Identity();
        // δ_ij d_k + δ_ik d_j: row i gets d, column i gets d
        h.row(i) += (2 * f1) * d.transpose();
        h.col(i) += (2 * f1) * d;
        out.hessian[i] += h;
    }
}

/// q^−m for q > 0; exact products and one sqrt when 2m is a small integer (the common falloffs),
/// std::pow otherwise.
Real powNeg(Real q, Real m, int twiceM) {
    if (twiceM < 0) return std::pow(q, -m);
    Real r = (twiceM & 1) ? std::sqrt(q) : Real(1);
    for (int k = 0; k < twiceM / 2; ++k) r *= q;
    return 1 / r;
}

Mat3 skew(const Vec3& a) {
    Mat3 m;
    m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
    return m;
}

/// Adds a swirl F = h(q) (a × d), q = ρ² = |P d|², P = 1 − a aᵀ, A = [a]×, w = A d, ρ = P d:
///   ∂F_i/∂x_j = h A_ij + 2 h' w_i ρ_j
///   ∂²F_i/∂x_j∂x_k = 2h' (A_ij ρ_k + A_ik ρ_j + w_i P_jk) + 4 h'' w_i ρ_j ρ_k.
void addSwirl(const Vec3& a, const Vec3& d, Real h, Real h1, Real h2, ForceOrder order, ForceSample& out) {
    const Vec3 w = a.cross(d);
    out.value += h * w;
    if (order == ForceOrder::Value) return;
    const Mat3 A = skew(a);
    const Vec3 rho = d - a.dot(d) * a;
    out.gradient += h * A + (2 * h1) * w * rho.transpose();
    if (order == ForceOrder::Gradient) return;
    const Mat3 P = Mat3::Identity() - a * a.transpose();
    const Mat3 rr = rho * rho.transpose();
    for (int i = 0; i < 3; ++i) {
        const Vec3 Ai = A.row(i).transpose();
        Mat3 m = Ai * rho.transpose() + rho * Ai.transpose();
        m *= 2 * h1;
        m += (2 * h1 * w[i]) * P + (4 * h2 * w[i]) * rr;
        out.hessian[i] += m;
    }
}

}  // namespace

void sinCos(Real theta, Real& sinOut, Real& cosOut) {
    if (!(std::abs(theta) <= 1e5)) {
        sinOut = std::sin(theta);
        cosOut = std::cos(theta);
        return;
    }
    // Cody-Waite: π/2 = pio2Hi + pio2Lo, pio2Hi with 33 significant bits, so n·pio2Hi is exact
    // for |n| < 2^20 (fdlibm's constants).
    constexpr Real kTwoOverPi = 6.36619772367581382433e-01;
    constexpr Real kPio2Hi = 1.57079632673412561417e+00;
    constexpr Real kPio2Lo = 6.07710050650619224932e-11;
    const Real n = std::floor(theta * kTwoOverPi + 0.5);
    const Real r = (theta - n * kPio2Hi) - n * kPio2Lo;  // |r| <= π/4 (+ a few ulp)
    const Real z = r * r;
    // fdlibm __kernel_sin / __kernel_cos minimax coefficients on [−π/4, π/4]
    const Real sr = r + r * z *
                            (-1.66666666666666324348e-01 +
                             z * (8.33333333332248946124e-03 +
                                  z * (-1.98412698298579493134e-04 +
                                       z * (2.75573137070700676789e-06 +
                                            z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    const Real hz = 0.5 * z, w = 1 - hz;
    const Real cr = w + (((1 - w) - hz) +
                         z * z *
                             (4.16666666666666019037e-02 +
                              z * (-1.38888888888741095749e-03 +
                                   z * (2.48015872894767294178e-05 +
                                        z * (-2.75573143513906633035e-07 +
                                             z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11))))));
    switch (static_cast<long long>(n) & 3) {
        case 0:
            sinOut = sr;
            cosOut = cr;
            break;
        case 1:
            sinOut = cr;
            cosOut = -sr;
            break;
        case 2:
            sinOut = -sr;
            cosOut = -cr;
            break;
        default:
            sinOut = -cr;
            cosOut = sr;
            break;
    }
}

Real Keyframes::at(Real frame) const {
    if (keys.empty()) return 0;
    if (frame <= keys.front().first) return keys.front().second;
    if (frame >= keys.back().first) return keys.back().second;
    // first key with frame > `frame` (keys.front() <= frame < keys.back() here)
    std::size_t lo = 0, hi = keys.size() - 1;
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        (keys[mid].first <= frame ? lo : hi) = mid;
    }
    const auto& [f0, v0] = keys[lo];
    const auto& [f1, v1] = keys[hi];
    const Real t = (frame - f0) / (f1 - f0);
    return v0 + t * (v1 - v0);
}

std::vector<std::string> ForceTerm::validate() const {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < strength.keys.size(); ++i) {
        const auto& [f, v] = strength.keys[i];
        if (!std::isfinite(f) || !std::isfinite(v))
            out.push_back("strength[" + std::to_string(i) + "]: expected finite numbers");
        else if (i > 0 && !(f > strength.keys[i - 1].first))
            out.push_back("strength[" + std::to_string(i) + "]: key frames must increase");
    }
    auto positive = [&](const char* name, Real v) {
        if (!(v > 0) || !std::isfinite(v))
            out.push_back(std::string(name) + ": expected a positive number, got " + got(v));
    };
    auto unit = [&](const char* name, const Vec3& v) {
        if (!finite(v) || !(v.norm() > 1e-12)) out.push_back(std::string(name) + ": expected a non-zero direction");
    };
    switch (kind) {
        case ForceKind::Gravity:
            unit("direction", direction);
            break;
        case ForceKind::Attractor:
            if (!finite(centre)) out.push_back("centre: expected finite numbers");
            positive("radius", radius);
            positive("softening", softening);
            if (!(falloff >= 0 && falloff <= 4))
                out.push_back("falloff: expected a number in [0, 4], got " + got(falloff));
            break;
        case ForceKind::Vortex:
            if (!finite(centre)) out.push_back("centre: expected finite numbers");
            unit("axis", axis);
            positive("radius", radius);
            if (!(falloff >= 0 && falloff <= 4))
                out.push_back("falloff: expected a number in [0, 4], got " + got(falloff));
            break;
        case ForceKind::Burst:
            if (!finite(centre)) out.push_back("centre: expected finite numbers");
            positive("radius", radius);
            break;
        case ForceKind::Wind:
            unit("direction", direction);
            if (!(turbulence >= 0) || !std::isfinite(turbulence))
                out.push_back("turbulence: expected a number >= 0, got " + got(turbulence));
            positive("scale", scale);
            if (modes < 1 || modes > 4096)
                out.push_back("modes: expected an integer in [1, 4096], got " + std::to_string(modes));
            break;
        case ForceKind::Linear:
            if (!finite(centre)) out.push_back("centre: expected finite numbers");
            if (!matrix.allFinite()) out.push_back("matrix: expected finite numbers");
            break;
        case ForceKind::Torsion:
            if (!finite(centre)) out.push_back("centre: expected finite numbers");
            unit("axis", axis);
            positive("radius", radius);
            break;
    }
    return out;
}

void ForceField::add(const ForceTerm& term) {
    const auto problems = term.validate();
    if (!problems.empty()) {
        const std::string& p = problems.front();
        const auto colon = p.find(':');
        throw InputError("force field", "terms[" + std::to_string(mTerms.size()) + "]." + p.substr(0, colon),
                         colon == std::string::npos ? p : p.substr(colon + 2));
    }
    ForceTerm t = term;
    t.direction.normalize();
    t.axis.normalize();
    WindModes wind;
    if (t.kind == ForceKind::Wind) {
        // Mode m: wave vector of uniformly random direction and length (2π/scale)·[0.5, 1.5);
        // amplitude of random direction in the plane ⊥ k, length sqrt(2/M) (rms |T| = 1);
        // random phase. Draw order is part of the format: changing it changes every scene.
        SplitMix64 rng(0x6467762D77696E64ull ^ (static_cast<std::uint64_t>(t.seed) * 0x9E3779B97F4A7C15ull));
        const Real amp = std::sqrt(2.0 / t.modes);
        for (int m = 0; m < t.modes; ++m) {
            const Real z = 2 * rng.uniform() - 1, az = kTwoPi * rng.uniform();
            const Real s = std::sqrt(std::max(Real(0), 1 - z * z));
            Real sinAz, cosAz;
            sinCos(az, sinAz, cosAz);
            const Vec3 dir(s * cosAz, s * sinAz, z);
            const Real k = kTwoPi / t.scale * (0.5 + rng.uniform());
            // orthonormal basis of the plane ⊥ dir
            const Vec3 helper = std::abs(dir.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
            const Vec3 e1 = dir.cross(helper).normalized();
            const Vec3 e2 = dir.cross(e1);
            const Real psi = kTwoPi * rng.uniform();
            wind.wave.push_back(k * dir);
            Real sinPsi, cosPsi;
            sinCos(psi, sinPsi, cosPsi);
            wind.amplitude.push_back(amp * (cosPsi * e1 + sinPsi * e2));
            wind.phase.push_back(kTwoPi * rng.uniform());
        }
    }
    Constants k;
    if (t.kind == ForceKind::Attractor || t.kind == ForceKind::Vortex) {
        k.exponent = 0.5 * (t.falloff + 1);
        k.scale = std::pow(t.radius, t.falloff) * (t.kind == ForceKind::Vortex ? std::pow(2.0, k.exponent) : 1.0);
        const Real twice = 2 * k.exponent;
        if (twice == std::floor(twice) && twice <= 16) k.twiceExponent = static_cast<int>(twice);
    }
    mTerms.push_back(t);
    mConst.push_back(k);
    mWind.push_back(std::move(wind));
}

void ForceField::accumulate(const Vec3& x, Real frame, ForceOrder order, ForceSample& out) const {
    for (std::size_t t = 0; t < mTerms.size(); ++t) {
        const ForceTerm& term = mTerms[t];
        const Real s = term.strength.at(frame);
        if (s == 0) continue;
        const Vec3 d = x - term.centre;
        switch (term.kind) {
            case ForceKind::Gravity:
                out.value += s * term.direction;
                break;
            case ForceKind::Attractor: {
                // f(q) = −s R^p (q + ε²)^−m, m = (p+1)/2
                const Constants& k = mConst[t];
                const Real m = k.exponent;
                const Real qe = d.squaredNorm() + term.softening * term.softening;
                const Real f = -s * k.scale * powNeg(qe, m, k.twiceExponent);
                addRadial(d, f, -m * f / qe, m * (m + 1) * f / (qe * qe), order, out);
                break;
            }
            case ForceKind::Vortex: {
                // h(q) = s 2^e R^n (q + R²)^−e, e = (n+1)/2, q = ρ²
                const Constants& k = mConst[t];
                const Real e = k.exponent;
                const Vec3 rho = d - term.axis.dot(d) * term.axis;
                const Real qr = rho.squaredNorm() + term.radius * term.radius;
                const Real h = s * k.scale * powNeg(qr, e, k.twiceExponent);
                addSwirl(term.axis, d, h, -e * h / qr, e * (e + 1) * h / (qr * qr), order, out);
                break;
            }
            case ForceKind::Burst: {
                // f(q) = (s/R) exp((1 − q/R²)/2)
                const Real r2 = term.radius * term.radius;
                const Real f = s / term.radius * std::exp(0.5 * (1 - d.squaredNorm() / r2));
                addRadial(d, f, -f / (2 * r2), f / (4 * r2 * r2), order, out);
                break;
            }
            case ForceKind::Wind: {
                out.value += s * term.direction;
                if (term.turbulence == 0) break;
                const WindModes& w = mWind[t];
                const Real a = s * term.turbulence;
                for (std::size_t m = 0; m < w.wave.size(); ++m) {
                    const Vec3& k = w.wave[m];
                    Real sn, cs;
                    sinCos(k.dot(x) + w.phase[m], sn, cs);
                    const Vec3 c = a * w.amplitude[m];
                    out.value += cs * c;
                    if (order == ForceOrder::Value) continue;
                    out.gradient.noalias() -= (sn * c) * k.transpose();
                    if (order == ForceOrder::Gradient) continue;
                    const Mat3 kk = k * k.transpose();
                    for (int i = 0; i < 3; ++i) out.hessian[i] -= (cs * c[i]) * kk;
                }
                break;
            }
            case ForceKind::Linear:
                out.value += s * (term.matrix * d);
                if (order != ForceOrder::Value) out.gradient += s * term.matrix;
                break;
            case ForceKind::Torsion: {
                // F = k z (a × d), k = s/R², z = a·d; ∇F = k((a × d) aᵀ + z [a]×);
                // ∂²F_i/∂d_j∂d_l = k([a]×_ij a_l + [a]×_il a_j)
                const Real k = s / (term.radius * term.radius);
                const Vec3& a = term.axis;
                const Real z = a.dot(d);
                Mat3 K;
                K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
                out.value += k * z * (K * d);
                if (order == ForceOrder::Value) break;
                out.gradient += k * ((K * d) * a.transpose() + z * K);
                if (order != ForceOrder::Hessian) break;
                for (int i = 0; i < 3; ++i) {
                    const Vec3 row = K.row(i).transpose();
                    out.hessian[static_cast<std::size_t>(i)] += k * (row * a.transpose() + a * row.transpose());
                }
                break;
            }
        }
    }
}

ForceSample ForceField::sample(const Vec3& x, Real frame, ForceOrder order) const {
    ForceSample out;
    accumulate(x, frame, order, out);
    return out;
}

void ForceField::sample(const std::vector<Vec3>& points, Real frame, ForceOrder order, ForceSamples& out) const {
    const std::size_t n = points.size();
    out.value.resize(n);
    if (order >= ForceOrder::Gradient)
        out.gradient.resize(n);
    else
        out.gradient.clear();
    for (auto& h : out.hessian) {
        if (order == ForceOrder::Hessian)
            h.resize(n);
        else
            h.clear();
    }
    parallelFor(
        static_cast<Index>(n),
        [&](Index p) {
            const auto i = static_cast<std::size_t>(p);
            ForceSample s;
            accumulate(points[i], frame, order, s);
            out.value[i] = s.value;
            if (order >= ForceOrder::Gradient) out.gradient[i] = s.gradient;
            if (order == ForceOrder::Hessian)
                for (int c = 0; c < 3; ++c) out.hessian[c][i] = s.hessian[c];
        },
        256);
}

}  // namespace dgv
