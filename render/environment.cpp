// The environment's irradiance in spherical harmonics (environment.hpp).

#include "render/environment.hpp"

#include <cmath>

namespace dgv {

namespace {

constexpr Real kPi = 3.14159265358979323846;

/// The real spherical harmonics l <= 2 at the unit vector d (y up).
std::array<Real, 9> basis(const Vec3& d) {
    const Real x = d.x(), y = d.y(), z = d.z();
    return {0.282095,         0.488603 * x,     0.488603 * y, 0.488603 * z, 1.092548 * x * z,
            1.092548 * x * y, 0.315392 * (3 * y * y - 1), 1.092548 * y * z, 0.546274 * (z * z - x * x)};
}

/// Â_l / π for the coefficient k (l = 0 for k = 0, 1 for k = 1..3, 2 for k = 4..8).
Real band(int k) { return k == 0 ? 1.0 : (k < 4 ? 2.0 / 3.0 : 0.25); }

}  // namespace

Environment uniformEnvironment(const Vec3& colour) {
    Environment e;
    // L_00 of a constant c is c · 4π Y_00; ambient = Y_00 · L_00 = c.
    e.coefficients[0] = colour / 0.282095;
    return e;
}

Environment skyEnvironment(const Vec3& sky, const Vec3& ground) {
    // L = (sky + ground)/2 + (sky − ground)/2 · sign(y): the sign's projection on Y_1 (0.488603 y)
    // is 0.488603 · 2π, its l = 2 terms vanish by symmetry, and the odd l >= 3 ones the cosine
    // lobe does not see; so ambient = (sky + ground)/2 + (sky − ground)/2 · n_y.
    Environment e;
    e.coefficients[0] = 0.5 * (sky + ground) / 0.282095;
    e.coefficients[2] = band(2) * 0.5 * (sky - ground) * 0.488603 * 2 * kPi;
    return e;
}

Environment equirectEnvironment(const std::vector<Vec3>& pixels, int width, int height, Real rotationDegrees) {
    Environment e;
    if (width <= 0 || height <= 0 || pixels.size() < static_cast<std::size_t>(width) * height) return e;
    const Real turn = rotationDegrees * kPi / 180;
    std::array<Vec3, 9> sum;
    sum.fill(Vec3::Zero());
    for (int row = 0; row < height; ++row) {
        const Real theta = (row + 0.5) * kPi / height;  // from the zenith
        const Real weight = (2 * kPi / width) * (kPi / height) * std::sin(theta);
        for (int col = 0; col < width; ++col) {
            const Real phi = 2 * kPi * ((col + 0.5) / width - 0.5) + turn;  // 0: along −z
            const Vec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
            const std::array<Real, 9> y = basis(d);
            const Vec3& c = pixels[static_cast<std::size_t>(row) * width + col];
            for (int k = 0; k < 9; ++k) sum[static_cast<std::size_t>(k)] += (weight * y[static_cast<std::size_t>(k)]) * c;
        }
    }
    for (int k = 0; k < 9; ++k) e.coefficients[static_cast<std::size_t>(k)] = band(k) * sum[static_cast<std::size_t>(k)];
    return e;
}

Vec3 ambientAt(const Environment& e, const Vec3& n) {
    const std::array<Real, 9> y = basis(n.normalized());
    Vec3 a = Vec3::Zero();
    for (int k = 0; k < 9; ++k) a += y[static_cast<std::size_t>(k)] * e.coefficients[static_cast<std::size_t>(k)];
    return a;
}

}  // namespace dgv
