#pragma once
/// @file sampled_distance.hpp
/// @brief The signed distance of a closed triangle mesh sampled on a regular grid, each block
/// of samples computed the first time a query needs it: the distance between bodies in contact
/// (sim/simulation, the other body's lattice surface; docs/gln.md, "Objects colliding").
///
/// It is a narrow-band level set of the mesh with its interior filled, read as an SdfGrid, with
/// exact samples: sample (i, j, k) at `voxel` · (i, j, k) in world space holds the exact signed
/// distance (MeshDistance, rounded to float), clamped above at `band` voxels outside; queries
/// interpolate trilinearly inside the samples' box and grow like a distance beyond it, by
/// SdfGrid's own rule (geom/sdf_grid.hpp). Only the blocks of 8³ samples a query touches
/// are computed, so a contact costs in proportion to the region where the bodies meet, not to
/// the surface of the whole body, and a block whose centre is more than the band plus its own
/// half-diagonal outside the mesh is filled with the clamp without a query per sample.
///
/// Queries are const and may run on any number of threads (a block is filled once, under its
/// own flag); the values do not depend on the order or the thread count.

#include "base/types.hpp"
#include "collide/mesh_distance.hpp"
#include "geom/triangle_mesh.hpp"

#include <memory>
#include <mutex>
#include <vector>

namespace dgv {

class SampledDistance {
public:
    /// `voxel` > 0 the sample spacing (world units); `bandVoxels` >= 1 the clamp outside.
    SampledDistance(const TriangleMesh& mesh, Real voxel, int bandVoxels);

    Real distance(const Vec3& x) const;
    /// Gradient of distance() at x (not normalised; about unit length within the band).
    Vec3 gradient(const Vec3& x) const;
    /// Both at once (one lookup of the eight samples).
    Real distance(const Vec3& x, Vec3* gradient) const;

    Real spacing() const { return mVoxel; }
    Vec3 origin() const { return mOrigin; }
    Vec3i dims() const { return mDims; }
    /// Blocks computed so far (for tests; not while queries run on other threads).
    std::size_t blocksFilled() const;

private:
    static constexpr int kBlock = 8;
    float sample(int i, int j, int k) const;
    void fill(std::size_t block) const;

    MeshDistance mMesh;
    Real mVoxel = 1, mBand = 1;
    Vec3 mOrigin = Vec3::Zero();
    Vec3i mDims = Vec3i::Zero(), mBlocks = Vec3i::Zero();
    std::unique_ptr<float[]> mValues;
    std::unique_ptr<std::once_flag[]> mOnce;
    std::unique_ptr<unsigned char[]> mFilled;
};

}  // namespace dgv
