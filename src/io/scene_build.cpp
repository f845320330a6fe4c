#include "io/scene_build.hpp"

#include "base/errors.hpp"
#include "base/progress.hpp"
#include "geom/primitives.hpp"
#include "io/mesh_import.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace dgv {

namespace {

/// The sizes dgv simulates and draws: under a micrometre the renderer's depth range draws
/// nothing (measured: 2e-7 m across was an empty image, 4e-7 m drew), past 1e9 m the dynamics'
/// squared and cubed lengths leave double's range long before the shot is meaningful.
constexpr Real kSmallestObject = 1e-6, kLargestObject = 1e9;
/// How far from the origin an object may lie, in multiples of its size: at 1e12 sizes a 1 m
/// jelly's cell volumes were off by 0.2 % (245 times their tolerance) with no fault, at 1e13 it
/// faulted, at 1e15 a solver's check failed; at 1e9 it ran as at the origin.
constexpr Real kFarthestInSizes = 1e9;

/// InputError for an object whose size (after scale and rotation, `mesh`) or position
/// (transform.translate) is outside what dgv resolves: said before any work, naming the key.
void checkPlacement(const TriangleMesh& mesh, const ObjectDesc& desc, const std::string& sceneFile, int index) {
    const std::string where = "objects[" + std::to_string(index) + "]";
    if (mesh.vertices.empty()) return;
    const Box3 box = meshBounds(mesh);
    const Real size = box.size().maxCoeff();
    const bool scaled = desc.transform.scale != Vec3::Ones();
    const std::string sizeKey = desc.isPrimitive && !scaled ? where + ".primitive" : where + ".transform.scale";
    char line[400];
    if (!std::isfinite(size) || size < kSmallestObject || size > kLargestObject) {
        std::snprintf(line, sizeof line,
                      "\"%s\" is %.3g m across; dgv simulates and draws objects from %.0e to %.0e m across: give "
                      "it a size in that range%s",
                      desc.name.c_str(), size, kSmallestObject, kLargestObject,
                      desc.isPrimitive ? "" : " (transform.scale or transform.units)");
        throw InputError(sceneFile, sizeKey, line);
    }
    const Vec3 centre = (box.min + box.max) / 2 + desc.transform.translate;
    const Real far = centre.lpNorm<Eigen::Infinity>();  // no overflow for any finite translate
    if (!std::isfinite(far) || far > kFarthestInSizes * size) {
        std::snprintf(line, sizeof line,
                      "\"%s\" would lie %.3g m from the origin along an axis, %.3g times its size (%.3g m); its voxels are "
                      "resolved within %.0e times its size (%.3g m): move the scene nearer the origin",
                      desc.name.c_str(), far, far / size, size, kFarthestInSizes, kFarthestInSizes * size);
        throw InputError(sceneFile, where + ".transform.translate", line);
    }
}

}  // namespace

TriangleMesh objectMesh(const ObjectDesc& desc, const std::string& sceneFile, int index) {
    const std::string where = "objects[" + std::to_string(index) + "]";
    TriangleMesh mesh;
    if (desc.isPrimitive) {
        const PrimitiveDesc& p = desc.primitive;
        switch (p.type) {
            case PrimitiveType::Sphere:
                mesh = makeSphere(p.radius);
                break;
            case PrimitiveType::Box:
                mesh = makeBox(p.size, 8);
                break;
            case PrimitiveType::Torus:
                mesh = makeTorus(p.majorRadius, p.minorRadius);
                break;
            case PrimitiveType::Capsule:
                mesh = makeCapsule(p.radius, p.height);
                break;
        }
    } else {
        MeshImportOptions opts;
        opts.meshName = desc.meshName;
        opts.unitScale = desc.transform.units;
        opts.materials = !desc.colorGiven;  // a scene's color overrides the file's look
        try {
            mesh = importMesh(desc.meshPath, opts);
        } catch (const InputError& e) {
            throw InputError(sceneFile, where + ".mesh", e.what());
        }
    }
    transformMesh(mesh, desc.transform.linear(), Vec3::Zero());
    checkPlacement(mesh, desc, sceneFile, index);
    transformMesh(mesh, Mat3::Identity(), desc.transform.translate);
    const std::string warning =
        desc.isPrimitive
            ? unlikelySizeWarning(mesh, "object '" + desc.name + "' (a primitive)", false)
            : unlikelySizeWarning(mesh, "object '" + desc.name + "' (" +
                                            std::filesystem::path(desc.meshPath).filename().string() + ")");
    if (!warning.empty()) logWarning(warning);
    return mesh;
}

void resolvePinGroups(SceneDesc& scene) {
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        ObjectDesc& desc = scene.objects[i];
        if (desc.pin.kind != PinDesc::Kind::Group) continue;
        MeshImportOptions opts;
        opts.meshName = desc.pin.group;
        opts.orientOutward = false;  // only the vertices are used
        opts.logUnitScale = false;   // said when the body's mesh was imported
        opts.unitScale = desc.transform.units;
        TriangleMesh group;
        try {
            group = importMesh(desc.meshPath, opts);
        } catch (const InputError& e) {
            throw InputError(scene.path, "objects[" + std::to_string(i) + "].pin.group", e.what());
        }
        transformMesh(group, desc.transform.linear(), desc.transform.translate);
        desc.pin.groupVertices = std::move(group.vertices);
    }
}

BuiltObject buildObject(const SceneDesc& scene, int index, std::size_t memoryBudget, double bytesPerPoint) {
    const ObjectDesc& desc = scene.objects[static_cast<std::size_t>(index)];
    BuiltObject obj;
    obj.name = desc.name;
    obj.restMesh = objectMesh(desc, scene.path, index);
    // Drawn in the file's materials where it has them; the colour is then theirs seen from afar
    // (the highlight's contrast and the footprints take it).
    obj.color = meanSurfaceColour(obj.restMesh, desc.color);
    obj.meshReport = analyseMesh(obj.restMesh);
    // A flat mesh (a single triangle, a plane) bounds no volume: voxelised as an open mesh it
    // becomes a sheet one voxel thick with no complete cell, whose dynamics went non-finite.
    {
        const Vec3 size = obj.meshReport.bounds.size();
        const Real largest = size.maxCoeff();
        for (int a = 0; a < 3; ++a)
            if (!(size[a] > 1e-9 * largest))
                throw InputError(scene.path, "objects[" + std::to_string(index) + "]",
                                 "the mesh of \"" + desc.name + "\" is flat (its size along " +
                                     std::string(1, "xyz"[a]) + " is 0), so it bounds no volume; give it a thickness");
    }
    try {
        VoxeliseSettings voxel = desc.voxel;
        if (memoryBudget > 0) voxel.memoryBudgetBytes = memoryBudget;
        voxel.bytesPerPoint = bytesPerPoint;
        obj.lattice = voxelise(obj.restMesh, voxel, &obj.voxelReport);
    } catch (const InputError& e) {
        throw InputError(scene.path, "objects[" + std::to_string(index) + "]." + e.where(), e.problem());
    }
    if (obj.lattice.size() == 0)
        throw InputError(scene.path, "objects[" + std::to_string(index) + "]",
                         "no voxel centre lies inside the mesh of \"" + desc.name +
                             "\" (is it open or flat, or the voxel size too large?)");
    // The material lattice is the points of complete cells (docs/math.md, "Loose points leave the
    // material lattice"); the mesh's vertices near a dropped voxel follow the nearest kept point.
    obj.lattice = withoutLoosePoints(obj.lattice, &obj.loosePoints);
    computeGeometricState(obj.lattice, restPositions(obj.lattice), obj.state);
    obj.embedding =
        embedVertices(obj.lattice, obj.restMesh.vertices, desc.material.solver == MaterialDesc::Solver::One);
    return obj;
}

std::vector<BuiltObject> buildObjects(const SceneDesc& scene, bool vdb) {
    // As sim/simulation decides which bodies it builds: any force or initial motion, or a cache.
    const bool simulated = vdb || sceneMoves(scene);
    const std::size_t budget = memoryBudgetBytes();
    std::size_t used = 0;
    std::vector<BuiltObject> objects;
    for (int i = 0; i < static_cast<int>(scene.objects.size()); ++i) {
        const ObjectDesc& desc = scene.objects[static_cast<std::size_t>(i)];
        const double perPoint = simulated && desc.deformable
                                    ? (vdb ? kSimulatedVdbBytesPerPoint : kSimulatedBytesPerPoint)
                                    : kLatticeBytesPerPoint;
        const std::size_t left = used < budget ? budget - used : 1;
        try {
            objects.push_back(buildObject(scene, i, left, perPoint));
        } catch (const InputError& e) {
            if (used == 0 || e.problem().find("budget") == std::string::npos) throw;
            throw InputError(e.input(), e.where(),
                             e.problem() + " (the objects before it take " + std::to_string(used >> 20) + " MiB of " +
                                 std::to_string(budget >> 20) + " MiB)");
        }
        used += static_cast<std::size_t>(perPoint * double(objects.back().lattice.size()));
    }
    // A VDB cache at its own voxel size: its world grid's active voxels are about the bodies'
    // material volume (kept by the dynamics) over the voxel's.
    const Real vs = scene.output.vdbVoxelSize;
    if (vdb && vs > 0) {
        double volume = 0;
        for (const BuiltObject& o : objects) {
            const double h = o.lattice.spacing;
            volume += double(o.lattice.size()) * h * h * h;
        }
        const double voxels = volume / (double(vs) * vs * vs);
        const double need = kVdbBytesPerVoxel * voxels;
        const double left = used < budget ? double(budget - used) : 0;
        if (need > left) {
            // The voxel size whose grid fits, rounded up to two significant digits.
            double fit = std::cbrt(kVdbBytesPerVoxel * volume / std::max(left, 1.0));
            const double decade = std::pow(10.0, std::floor(std::log10(fit)) - 1);
            fit = std::ceil(fit / decade) * decade;
            char what[400];
            std::snprintf(what, sizeof what,
                          "%.3g would make a world grid of ~%.3g voxels a frame (~%.0f MiB), more than the %.0f MiB "
                          "the memory budget leaves (%zu MiB, the objects take %zu); vdb_voxel_size %.2g would fit, "
                          "or 0 for the lattice spacing",
                          double(vs), voxels, need / (1 << 20), left / (1 << 20), budget >> 20, used >> 20, fit);
            throw InputError(scene.path, "output.vdb_voxel_size", what);
        }
    }
    for (const BuiltObject& o : objects) {  // after the checks: a refusal is one line
        logInfo(describe(o));
        const std::string thin = unresolvedWarning(o);
        if (!thin.empty()) logWarning(thin);
    }
    return objects;
}

std::string unresolvedWarning(const BuiltObject& o) {
    const Index far = o.embedding.farVertices();
    const std::size_t nv = o.embedding.size();
    if (nv == 0 || Real(far) < kUnresolvedShare * Real(nv)) return {};
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "object '%s': %lld of its %zu vertices lie %.1f voxels or more from its lattice: parts thinner than "
                  "the lattice resolves (legs, fins, a tail) follow the material near them without dynamics of their "
                  "own; a higher 'resolution' simulates them",
                  o.name.c_str(), static_cast<long long>(far), nv, double(kFitFull));
    return buf;
}

std::string describe(const BuiltObject& o) {
    char buf[512];
    const VoxeliseReport& v = o.voxelReport;
    std::snprintf(buf, sizeof buf,
                  "object '%s': %zu triangles%s, lattice %dx%dx%d with %lld material points "
                  "(h = %.4g; %lld loose voxels in no complete cell dropped), %d component%s",
                  o.name.c_str(), o.meshReport.triangles, o.meshReport.closed ? " (closed)" : " (open)", v.dims.x(),
                  v.dims.y(), v.dims.z(), static_cast<long long>(o.lattice.size()), v.spacing,
                  static_cast<long long>(o.loosePoints), o.lattice.components, o.lattice.components == 1 ? "" : "s");
    return buf;
}

}  // namespace dgv
