#pragma once
/// @file mat3.hpp
/// @brief Closed forms on 3 × 3 matrices that more than one module needs.

#include "base/types.hpp"

namespace dgv {

/// Cofactor matrix of M: cof(M)(i, j) = (-1)^(i+j) minor_ij = d det(M) / d M(i, j).
/// cof(M) = det(M) M^-T for invertible M; its transpose is the adjugate.
inline Mat3 cofactor(const Mat3& M) {
    Mat3 C;
    C(0, 0) = M(1, 1) * M(2, 2) - M(1, 2) * M(2, 1);
    C(0, 1) = M(1, 2) * M(2, 0) - M(1, 0) * M(2, 2);
    C(0, 2) = M(1, 0) * M(2, 1) - M(1, 1) * M(2, 0);
    C(1, 0) = M(0, 2) * M(2, 1) - M(0, 1) * M(2, 2);
    C(1, 1) = M(0, 0) * M(2, 2) - M(0, 2) * M(2, 0);
    C(1, 2) = M(0, 1) * M(2, 0) - M(0, 0) * M(2, 1);
    C(2, 0) = M(0, 1) * M(1, 2) - M(0, 2) * M(1, 1);
    C(2, 1) = M(0, 2) * M(1, 0) - M(0, 0) * M(1, 2);
    C(2, 2) = M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0);
    return C;
}

}  // namespace dgv
