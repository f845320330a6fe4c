// The signed distance of a closed mesh sampled on a grid, block by block on demand
// (sampled_distance.hpp).

#include "collide/sampled_distance.hpp"

#include "base/check.hpp"
#include "geom/sdf_grid.hpp"

#include <algorithm>
#include <cmath>

namespace dgv {

SampledDistance::SampledDistance(const TriangleMesh& mesh, Real voxel, int bandVoxels)
    : mMesh(mesh), mVoxel(voxel), mBand(voxel * bandVoxels) {
    DGV_CHECK(voxel > 0 && bandVoxels >= 1 && !mMesh.empty());
    // The samples cover the mesh's box and the band around it, on the world lattice of `voxel`
    // (sample (i, j, k) at voxel · (i, j, k), as a level set built on that transform has them),
    // with one sample more on each side: beyond the band every sample is the clamp.
    const Box3& b = mMesh.bounds();
    Vec3i lo, hi;
    for (int a = 0; a < 3; ++a) {
        lo[a] = static_cast<int>(std::floor(b.min[a] / voxel)) - bandVoxels - 1;
        hi[a] = static_cast<int>(std::ceil(b.max[a] / voxel)) + bandVoxels + 1;
    }
    mOrigin = voxel * lo.cast<Real>();
    mDims = hi - lo + Vec3i::Ones();
    for (int a = 0; a < 3; ++a) mBlocks[a] = (mDims[a] + kBlock - 1) / kBlock;
    const std::size_t blocks = static_cast<std::size_t>(mBlocks.x()) * static_cast<std::size_t>(mBlocks.y()) *
                               static_cast<std::size_t>(mBlocks.z());
    mValues.reset(new float[blocks * kBlock * kBlock * kBlock]);
    mOnce.reset(new std::once_flag[blocks]);
    mFilled.reset(new unsigned char[blocks]());
}

std::size_t SampledDistance::blocksFilled() const {
    const std::size_t blocks = static_cast<std::size_t>(mBlocks.prod());
    return static_cast<std::size_t>(std::count(mFilled.get(), mFilled.get() + blocks, 1));
}

void SampledDistance::fill(std::size_t block) const {
    const int bx = static_cast<int>(block % static_cast<std::size_t>(mBlocks.x()));
    const int by =
        static_cast<int>(block / static_cast<std::size_t>(mBlocks.x()) % static_cast<std::size_t>(mBlocks.y()));
    const int bz =
        static_cast<int>(block / (static_cast<std::size_t>(mBlocks.x()) * static_cast<std::size_t>(mBlocks.y())));
    float* v = mValues.get() + block * kBlock * kBlock * kBlock;
    const Vec3i first(bx * kBlock, by * kBlock, bz * kBlock);
    // A block whose centre lies farther outside than the band and its half-diagonal holds only
    // the clamp (the distance is 1-Lipschitz).
    const Real half = Real(0.5) * (kBlock - 1) * mVoxel;
    const Real reach = half * std::sqrt(Real(3));
    const Real centre =
        mMesh.signedDistance(mOrigin + mVoxel * first.cast<Real>() + Vec3::Constant(half), nullptr, mBand + reach);
    if (centre >= mBand + reach) {
        std::fill(v, v + kBlock * kBlock * kBlock, static_cast<float>(mBand));
    } else {
        for (int k = 0; k < kBlock; ++k)
            for (int j = 0; j < kBlock; ++j)
                for (int i = 0; i < kBlock; ++i) {
                    // Where SdfGrid's rule puts sample (i, j, k): origin + spacing · (i, j, k).
                    const Vec3 x = mOrigin + mVoxel * (first + Vec3i(i, j, k)).cast<Real>();
                    const Real d = mMesh.signedDistance(x, nullptr, mBand);
                    v[i + kBlock * (j + kBlock * k)] = static_cast<float>(std::min(d, mBand));
                }
    }
    mFilled[block] = 1;
}

float SampledDistance::sample(int i, int j, int k) const {
    const std::size_t block = static_cast<std::size_t>(i / kBlock) +
                              static_cast<std::size_t>(mBlocks.x()) *
                                  (static_cast<std::size_t>(j / kBlock) +
                                   static_cast<std::size_t>(mBlocks.y()) * static_cast<std::size_t>(k / kBlock));
    std::call_once(mOnce[block], [&] { fill(block); });
    return mValues[block * kBlock * kBlock * kBlock +
                   static_cast<std::size_t>(i % kBlock + kBlock * (j % kBlock + kBlock * (k % kBlock)))];
}

Real SampledDistance::distance(const Vec3& x) const {
    return sdfDistance(mOrigin, mVoxel, mDims, x, [this](int i, int j, int k) { return Real(sample(i, j, k)); });
}

Vec3 SampledDistance::gradient(const Vec3& x) const {
    return sdfGradient(mOrigin, mVoxel, mDims, x, [this](int i, int j, int k) { return Real(sample(i, j, k)); });
}

Real SampledDistance::distance(const Vec3& x, Vec3* gradient) const {
    if (!gradient) return distance(x);
    return sdfDistance(
        mOrigin, mVoxel, mDims, x, [this](int i, int j, int k) { return Real(sample(i, j, k)); }, *gradient);
}

}  // namespace dgv
