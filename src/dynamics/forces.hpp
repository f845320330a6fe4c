#pragma once
/// @file forces.hpp
/// @brief External force fields of the dynamics (seed eqs 64-74): value F(x), gradient ∇F and
/// Hessian ∇∇F, analytic, for gravity, a softened point attractor/repeller, a vortex about an
/// axis, a radial burst, wind with divergence-free curl-noise turbulence, a linear field, and
/// sums of them; strength keyframed over scene frames.
///
/// Units. F is an acceleration (force per unit mass, the seed's eq 64 ẍ = F[x]) in world units
/// per second squared (m/s²); ∇F is in 1/s², ∇∇F in 1/(m s²). Positions are world units.
///
/// Index convention (ForceSample):
///   gradient(i, j)   = ∂F_i / ∂x_j                 (row i: component of F, column j: derivative)
///   hessian[i](j, k) = ∂²F_i / ∂x_j ∂x_k           (each hessian[i] symmetric)
/// The seed's products map onto these as
///   eq 69:    x_a · ∇F                 = gradient * x_a                (the derivative along x_a)
///   eq 70/74: (x_a x_b) : ∇∇F          = contractHessian(hessian, x_a, x_b),
///             whose component i is x_aᵀ hessian[i] x_b.
/// The divergence of F is gradient.trace(); a field is curl-free where gradient is symmetric.
///
/// Time. A field is evaluated at a scene frame (fractional between frames for substeps): every
/// term's strength is a Keyframes curve, linear between keys and held outside them, exactly the
/// scene file's `strength` (io/scene_json). Everything else about a term is fixed.
///
/// Determinism. Evaluation is a pure function of (term parameters, seed, point, frame); the bulk
/// evaluation writes per point, so it is bit-identical for any thread count.

#include "base/types.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace dgv {

/// A scalar keyed over scene frames: linear interpolation between keys, held constant outside
/// them; zero when there are no keys. The scene file's `strength` is read into it directly
/// (io/scene_json: one key, or [frame, value] pairs with increasing frames).
struct Keyframes {
    std::vector<std::pair<Real, Real>> keys;  ///< (frame, value), frames strictly increasing

    static Keyframes constant(Real value) { return Keyframes{{{0, value}}}; }
    Real at(Real frame) const;
};

/// A field's value and derivatives at one point (index convention in the file comment).
struct ForceSample {
    Vec3 value = Vec3::Zero();     ///< F, m/s²
    Mat3 gradient = Mat3::Zero();  ///< gradient(i, j) = ∂F_i/∂x_j, 1/s²
    std::array<Mat3, 3> hessian = {Mat3::Zero(), Mat3::Zero(),
                                   Mat3::Zero()};  ///< hessian[i](j, k) = ∂²F_i/∂x_j∂x_k, 1/(m s²)
};

/// How much of a sample to compute; higher orders include the lower ones.
enum class ForceOrder : int { Value = 0, Gradient = 1, Hessian = 2 };

/// The kinds of field (formulas at each field of ForceTerm; docs/math.md "Force fields").
enum class ForceKind { Gravity, Attractor, Vortex, Burst, Wind, Linear, Torsion };

/// One term of a force field. Fields that a kind does not use are ignored. With s the strength
/// at the frame, d = x − centre:
///  - Gravity:   F = s·direction.
///  - Attractor: F = −s·R^p·d / (|d|² + ε²)^((p+1)/2), R = radius, ε = softening, p = falloff
///               (2: Plummer-softened inverse square). |F| = s at |d| = R when ε ≪ R; smooth
///               (linear, F ≈ −s R^p ε^−(p+1) d) inside ε. s < 0 repels.
///  - Vortex:    F = s·2^e·R^n·(a × d) / (ρ² + R²)^e, e = (n+1)/2, a = axis, ρ = |d − (d·a)a|,
///               R = radius (the core), n = falloff (1: the Scully vortex, |F| peaks at ρ = R).
///               |F| = s at ρ = R; tangential (F·d = 0, F·a = 0), divergence-free; rotation
///               about a by the right-hand rule for s > 0; solid-body (|F| ∝ ρ) inside the core.
///  - Burst:     F = (s/R)·d·exp((1 − |d|²/R²)/2): outward, |F| peaks at s at |d| = R and decays
///               like a Gaussian beyond; smooth through the centre. Key the strength to fire it.
///  - Wind:      F = s·(direction + turbulence·T(x)), T the curl of a smooth vector potential made
///               of `modes` seeded random Fourier modes of wavelength ≈ scale (0.67..2 × scale):
///               T(x) = Σ_m c_m cos(k_m·x + φ_m), c_m ⊥ k_m, so div T = 0 exactly; rms |T| = 1.
///               An acceleration field, not drag: it does not depend on velocity (seed eq 64).
///  - Torsion:   F = s·(z/R)·(a × d)/R, z = a·d: every layer across the axis a turns, at a rate
///               growing linearly with its height z above the centre (|F| = s at z = ρ = R). Its
///               Hessian is constant and non-zero, so it twists a body (a column pinned at z = 0).
///  - Linear:    F = s·(matrix·d): constant gradient s·matrix, zero Hessian (tests, and the
///               closed-form affine motion of the dynamics tests).
struct ForceTerm {
    ForceKind kind = ForceKind::Gravity;
    Keyframes strength = Keyframes::constant(1);  ///< s: m/s² (gravity, attractor, vortex, burst, wind); 1/s² (linear)
    Vec3 direction = Vec3(0, -1, 0);              ///< gravity, wind mean direction; made unit on add()
    Vec3 centre = Vec3::Zero();                   ///< attractor, burst, linear: the centre; vortex: a point on the axis
    Vec3 axis = Vec3::UnitY();                    ///< vortex; made unit on add()
    Real radius = 1;                              ///< R, metres: attractor reference distance, vortex core, burst peak
    Real softening = 0.25;                        ///< ε, metres, > 0: attractor softening radius
    Real falloff = 2;                             ///< attractor p (default 2), vortex n (scene default 1); in [0, 4]
    Real turbulence = 0;                          ///< wind: amplitude of T relative to the mean (>= 0)
    Real scale = 1;                               ///< wind: noise feature size (wavelength), metres, > 0
    std::uint32_t seed = 1;                       ///< wind: noise seed
    int modes = 32;                               ///< wind: number of Fourier modes, 1..4096
    Mat3 matrix = Mat3::Zero();                   ///< linear: the gradient at unit strength

    /// Problems by field name ("softening: expected a positive number, got 0"); empty when valid.
    std::vector<std::string> validate() const;
};

/// Bulk samples, structure of arrays over points; only the orders asked for are filled, the
/// others are left empty.
struct ForceSamples {
    std::vector<Vec3> value;                   ///< F per point
    std::vector<Mat3> gradient;                ///< ∇F per point (order >= Gradient)
    std::array<std::vector<Mat3>, 3> hessian;  ///< hessian[i][p] = ∂²F_i/∂x∂x at p (order Hessian)
};

/// A sum of force terms. Copyable, immutable once built; evaluation is thread-safe.
class ForceField {
public:
    /// Appends a term. Validates it (throws InputError{"force field", "terms[i].<field>", what}
    /// on a problem), normalises its direction and axis and, for wind, draws its Fourier modes
    /// from its seed.
    void add(const ForceTerm& term);

    const std::vector<ForceTerm>& terms() const { return mTerms; }
    bool empty() const { return mTerms.empty(); }

    /// Value and derivatives (up to `order`) of the sum of the terms at x (world units), at
    /// scene frame `frame`. Orders not asked for are left zero.
    ForceSample sample(const Vec3& x, Real frame, ForceOrder order = ForceOrder::Hessian) const;

    /// F(x) only.
    Vec3 value(const Vec3& x, Real frame) const { return sample(x, frame, ForceOrder::Value).value; }

    /// sample() at every point, in parallel; bit-identical for any thread count. `out` is
    /// resized (its storage reused when sizes match).
    void sample(const std::vector<Vec3>& points, Real frame, ForceOrder order, ForceSamples& out) const;

private:
    struct WindModes {
        std::vector<Vec3> wave;       ///< k_m, radians per metre
        std::vector<Vec3> amplitude;  ///< c_m ⊥ k_m
        std::vector<Real> phase;      ///< φ_m
    };
    void accumulate(const Vec3& x, Real frame, ForceOrder order, ForceSample& out) const;

    /// Per-term constants, fixed on add().
    struct Constants {
        Real scale = 1;          ///< attractor R^p; vortex 2^e R^n
        Real exponent = 0;       ///< attractor m = (p+1)/2; vortex e = (n+1)/2
        int twiceExponent = -1;  ///< 2·exponent when it is an integer (sqrt and products, no pow)
    };
    std::vector<ForceTerm> mTerms;
    std::vector<Constants> mConst;
    std::vector<WindModes> mWind;  ///< per term; empty for terms that are not wind
};

// ---- per-point kernels (pure; used by ForceField, exposed for tests) ----------------------

/// sin θ and cos θ, to within 2 ulp of the correctly rounded values for |θ| <= 1e5 (Cody-Waite
/// reduction by π/2, fdlibm's minimax kernels), std::sin/std::cos beyond. About 3× faster than
/// the two library calls, deterministic (plain arithmetic). The wind's Fourier modes spend most
/// of their time here.
void sinCos(Real theta, Real& sinOut, Real& cosOut);

/// The seed's (x_a x_b) : ∇∇F (eqs 70, 74, 76): component i is x_aᵀ hessian[i] x_b. Symmetric
/// in (x_a, x_b).
inline Vec3 contractHessian(const std::array<Mat3, 3>& hessian, const Vec3& xa, const Vec3& xb) {
    return Vec3(xa.dot(hessian[0] * xb), xa.dot(hessian[1] * xb), xa.dot(hessian[2] * xb));
}

}  // namespace dgv
