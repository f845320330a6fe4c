#pragma once
/// @file scene.hpp
/// @brief A scene as dgv runs it: plain settings structs, already validated and with every
/// path resolved. io/scene_json maps a scene file onto these (scenes/README.md is the schema);
/// the pipeline stages read them. World units are metres, right-handed, Y up.

#include "base/light.hpp"
#include "base/types.hpp"
#include "dynamics/forces.hpp"
#include "geom/sdf_grid.hpp"
#include "geom/triangle_mesh.hpp"
#include "geom/voxelise.hpp"

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace dgv {

/// Scale, then rotate (Euler angles in degrees, applied about X, then Y, then Z), then translate.
struct TransformDesc {
    Vec3 translate = Vec3::Zero();
    Vec3 rotateDegrees = Vec3::Zero();
    Vec3 scale = Vec3::Ones();
    /// Metres per unit of the mesh file (`transform.units`), applied on import in place of the
    /// file's own unit (FBX's UnitScaleFactor); 0: the file's.
    Real units = 0;

    Mat3 linear() const;  ///< R * S
};

enum class PrimitiveType { Sphere, Box, Torus, Capsule };

struct PrimitiveDesc {
    PrimitiveType type = PrimitiveType::Sphere;
    Real radius = 0.5;         ///< sphere, capsule
    Vec3 size = Vec3::Ones();  ///< box edge lengths
    Real majorRadius = 0.5;    ///< torus: centre to tube centre
    Real minorRadius = 0.2;    ///< torus: tube radius
    Real height = 1.0;         ///< capsule: distance between hemisphere centres
};

/// How a deformable object's material responds (dynamics/stepper.hpp DynamicsSettings).
/// An object's material as the scene gives it. The shape memory's stiffness comes from one of
/// `stiffness` (1/s²), `wobble_hz` or `sag`, the damping from `damping` or `wobbles`; a
/// `preset` (jelly, the default; putty; goo) fills what the object does not give.
/// sim/simulation resolves them on the object's lattice (resolvedStiffness, resolvedDamping).
struct MaterialDesc {
    enum class StiffnessFrom { Value, WobbleHz, Sag };
    Real density = 1000;  ///< kg/m^3
    /// How each substep is solved (DynamicsSettings::solver): the notes' stages in turn ("chain",
    /// the default) or one minimisation ("one"; docs/math.md, "The one-solve step").
    enum class Solver { Chain, One } solver = Solver::Chain;
    Real damping = 1;     ///< 1/s: twist and flex stretch rates decay as exp(-damping t)
    Real viscosity = 0;   ///< m²/s: kinematic viscosity (DynamicsSettings::viscosity)
    StiffnessFrom stiffnessFrom = StiffnessFrom::Sag;
    Real stiffness = 0;  ///< 1/s^2: shape memory (0: goo; > 0: jelly that wobbles back)
    Real wobbleHz = 0;   ///< the wobble's frequency √k/2π (stiffnessFrom WobbleHz)
    /// The resting sag under standard gravity as a share of the body's half height r (its rest
    /// extent along y over 2): k = 5 g/(sag r) (stiffnessFrom Sag). Size-independent firmness.
    Real sag = 0.1;
    /// > 0: the damping is set so that a wobble's amplitude falls to a tenth over this many
    /// periods, damping = 2 f ln 10 / wobbles (f = √k/2π); 0: `damping` as given.
    Real wobbles = 3;
    Real yield = 0;               ///< plasticity: the largest elastic log strain (0: off; needs stiffness)
    Real volumeTolerance = 1e-5;  ///< the volume projection's max |V/V0 − 1| per cell after a step
    Real maxDeltaGamma = 0.05;    ///< limiter on the connection change per step
    bool pinnedLoad = true;       ///< a pinned body's load modes (DynamicsSettings::pinnedLoad)
    /// Goo re-voxelised in its current shape when its lattice distorts (sim/simulation,
    /// docs/math.md "Re-parametrisation"); false keeps the lattice it starts with.
    bool reparametrise = true;
};

/// Material points held fixed: those whose rest position lies in a box or a ball (world units),
/// or those that carry a vertex group of the object's mesh file (a named mesh or node, e.g. an
/// OBJ `g` group: Blender's OBJ export writes vertex groups so) — the 8 corners of each group
/// vertex's lattice cell, or its anchor point near the surface (geom/embedding).
/// The shape memory's stiffness k (1/s²) of `m` on a body whose rest points span `halfHeight`
/// metres above and below their middle along y (MaterialDesc::sag).
Real resolvedStiffness(const MaterialDesc& m, Real halfHeight);
/// The damping (1/s) of `m` for the stiffness k (MaterialDesc::wobbles; `damping` when k = 0).
Real resolvedDamping(const MaterialDesc& m, Real stiffness);

struct PinDesc {
    enum class Kind { None, Box, Ball, Group } kind = Kind::None;
    Vec3 min = Vec3::Zero(), max = Vec3::Zero();  ///< box
    Vec3 centre = Vec3::Zero();                   ///< ball
    Real radius = 0;                              ///< ball
    std::string group;                            ///< group: the mesh or node name in the object's mesh file
    /// group: its vertices at rest (world units, the object's transform applied), read by the
    /// app before the simulation is built (io/scene_build resolvePinGroups)
    std::vector<Vec3> groupVertices;
    bool contains(const Vec3& x) const;
};

struct ObjectDesc {
    std::string name;
    bool isPrimitive = false;
    PrimitiveDesc primitive;
    std::string meshPath;  ///< absolute (resolved against the scene file's folder)
    std::string meshName;  ///< import only this mesh/node of the file; empty: all
    TransformDesc transform;
    VoxeliseSettings voxel;
    Vec3 color = Vec3(0.8, 0.8, 0.8);  ///< linear RGB (the file gives sRGB)
    /// `color` was written: it overrides the mesh file's materials and textures (without it a
    /// mesh file's own look is drawn, where it has one; docs/rendering.md, "Materials").
    bool colorGiven = false;
    bool deformable = true;
    MaterialDesc material;
    Vec3 velocity = Vec3::Zero();     ///< initial velocity of the centre, m/s
    Vec3 spinDegrees = Vec3::Zero();  ///< initial angular velocity, degrees/s (rigid spin)
    PinDesc pin;
};

enum class ColliderType { Ground, Sphere, Mesh, LevelSet, Plane };

struct ColliderDesc {
    ColliderType type = ColliderType::Ground;
    Real height = 0;             ///< ground: y of the plane
    Vec3 centre = Vec3::Zero();  ///< sphere; plane: a point on it (the drawn square's centre)
    Real radius = 1;             ///< sphere
    Vec3 normal = Vec3::UnitY();  ///< plane: unit, pointing out of the solid side
    Real size = 2;                ///< plane: the side of the square drawn (the collider is the whole plane)
    std::string meshPath;        ///< mesh (absolute)
    TransformDesc transform;     ///< mesh, levelset (levelset: uniform scale only)
    std::string levelSetPath;    ///< levelset: the .vdb file (absolute)
    std::string levelSetGrid;    ///< levelset: grid name; empty: the first level set
    /// levelset: the grid, loaded by the scene reader (io/scene_json.cpp; never null after it);
    /// mesh: the signed distance to the transformed mesh, in world space (identity transform)
    std::shared_ptr<const SdfGrid> levelSet;
    Real meshVoxelSize = 0;  ///< mesh: the level set's voxel; 0: longest edge / 128
    /// mesh: the imported mesh with `transform` applied (world space), for drawing
    std::shared_ptr<const TriangleMesh> worldMesh;
    Real friction = 0.5;     ///< 0: slip, 1: sticky
    Real restitution = 0.0;  ///< elastic bounce, 0..1
};

/// A closed curve drawn as a tube, for the Gauss-linking-number figures (seed section 5, figures
/// 1-4; app/curve_scene.cpp, docs/gln.md). A ring or a curve file, moved rigidly (no rotation).
struct CurveDesc {
    std::string name;
    std::string curvePath;                      ///< a curve file (absolute, io/curve_file.hpp); empty: a ring
    Vec3 centre = Vec3::Zero();                 ///< ring: centre
    Vec3 normal = Vec3::UnitY();                ///< ring: unit normal of its plane (vertices CCW about it)
    Real radius = 1;                            ///< ring: radius
    int segments = 256;                         ///< ring: vertices (vertex 0 at centre + radius·u, u the
                                                ///< coordinate axis least aligned with normal, projected)
    std::vector<std::pair<Real, Vec3>> motion;  ///< (frame, offset) keys, linear, held outside
    Vec3 color = Vec3(0.8, 0.8, 0.8);           ///< linear RGB (the file gives sRGB)
    Real tubeRadius = 0.02;                     ///< drawn tube radius (world units)

    Vec3 offsetAt(Real frame) const;  ///< the motion's offset at `frame` (zero without keys)
};

/// What a scene with curves measures per frame (out/<scene>/gln.csv and the plots).
struct GlnFigureDesc {
    std::vector<Real> seedTolerances = {10, 1};  ///< one gln_seed_tol<T> column each
};

enum class CameraType { Turntable, LookAt, Keyframed };

/// One key of a keyframed camera: at `frame` the camera is at `eye`, looks at `target`, with
/// vertical field of view `fovDegrees`. Between keys each is interpolated linearly.
/// A field of view given as a lens, as in Maya, Houdini and Blender: a focal length and a sensor
/// (film back) in millimetres. The sensor spans the image's longer side (Blender's "auto" fit),
/// so the vertical field of view depends on the render's aspect (FieldOfView::vertical).
struct Lens {
    Real focalLengthMm = 50;
    Real sensorMm = 36;
};

/// The vertical field of view, in degrees, of `lens` on an image of width/height `aspect`.
Real lensVerticalFovDegrees(const Lens& lens, Real aspect);

/// A field of view as a camera or a key gives it: `fov`, or a lens instead.
struct FieldOfView {
    Real fovDegrees = 35;      ///< vertical field of view
    std::optional<Lens> lens;  ///< focal_length (and sensor) instead of fov
    /// The vertical field of view in degrees on an image of width/height `aspect`.
    Real vertical(Real aspect) const { return lens ? lensVerticalFovDegrees(*lens, aspect) : fovDegrees; }
};

struct CameraKey : FieldOfView {
    Real frame = 1;
    Vec3 eye = Vec3(0, 1, 5);
    Vec3 target = Vec3::Zero();
};

struct CameraDesc : FieldOfView {
    CameraType type = CameraType::Turntable;
    // turntable: orbits `degrees` over the frame range, starting at `startDegrees`, framed on
    // the bounds of all objects at rest
    Real degrees = 360;
    Real startDegrees = 0;
    Real elevationDegrees = 20;
    Real margin = 1.1;
    // look_at
    Vec3 eye = Vec3(0, 1, 5);
    Vec3 target = Vec3::Zero();
    Vec3 up = Vec3::UnitY();
    // keyframed: frames increasing; held before the first and after the last key (up as above)
    std::vector<CameraKey> keys;
    /// camera.depth_of_field: each frame the mean of `dofSamples` views through a lens of
    /// focal length / f-stop aperture, sharp at `focusDistance` (0: the distance from the eye to
    /// the target, a turntable's the shapes' centre).
    bool depthOfField = false;
    Real fStop = 2.8;
    Real focusDistance = 0;
    int dofSamples = 16;
};

/// render.contact.mode: how the contact set R shows on a surface (view/contact_highlight).
enum class ContactHighlightMode {
    Off,
    Depth,   ///< scalar = penetration depth before the response (world units) where in R, else 0
    Recent,  ///< scalar = 1 − age/fade for points in R within the last `fade` frames, else 0
};

/// render.overlays.lattice_set: which lattice points the dots show (view/lattice_overlay).
enum class LatticeDotSet {
    Boundary,  ///< the surface layer (points missing a neighbour) on the side facing the camera
    All,       ///< every point, interior too
};

/// render.overlays.gln_loop_set: which GLN network loops are drawn (view/gln_overlay).
enum class GlnLoopSet {
    Contact,  ///< the fine rings of the points in the contact set R (the rings that linked)
    All,      ///< every fine ring (one per boundary point)
    Coarse,   ///< every coarse ring (a cover of the boundary, 2 voxels across)
};

struct RenderDesc {
    int width = 640;
    int height = 360;
    int supersample = 2;
    Vec3 background = Vec3(0.18, 0.19, 0.21);  ///< linear RGB (the file gives sRGB)
    bool transparent = false;
    bool ground = true;
    bool groundGiven = false;  ///< the scene sets render.ground (view/frame_view: the floor of a moving shot)
    int bitDepth = 8;
    /// The frames' files: PNG (sRGB, bitDepth) or OpenEXR (linear half float with premultiplied
    /// alpha, and the depth Z and the contact matte as extra channels; io/exr.hpp).
    enum class Format { Png, Exr } format = Format::Png;
    const char* frameExtension() const { return format == Format::Exr ? "exr" : "png"; }
    Real creaseDegrees = 40;   ///< normals split along edges sharper than this (180: smooth)
    std::vector<Light> lights;  ///< render.lights; empty: the studio rig attached to the camera
    Real shadowSoftness = 3;   ///< the key light's angular radius, degrees (0: hard shadows)
    Real colliderOpacity = 1;  ///< colliders drawn see-through below 1 (an x-ray view of the contact behind them)
    /// render.motion_blur: each frame the average of `motionBlurSamples` renders spread over the
    /// shutter, which closes at the frame's time and stays open `motionBlurShutter` degrees of the
    /// frame (180: half of it). The bodies at the simulation's own substeps, the camera on its path.
    /// render.environment: the ambient light from every direction. Studio: the sky and bounce
    /// hemisphere; Colour: one colour; Sky: `environmentColour` above the horizon,
    /// `environmentGround` below; Image: an equirectangular image (linear, rows from the zenith),
    /// turned `environmentRotation` degrees about the vertical. Each times `environmentIntensity`.
    enum class Environment { Studio, Colour, Sky, Image } environment = Environment::Studio;
    Vec3 environmentColour = Vec3::Ones();  ///< linear RGB
    Vec3 environmentGround = Vec3::Zero();  ///< linear RGB
    std::string environmentImage;           ///< the image file (absolute)
    std::shared_ptr<const std::vector<Vec3>> environmentPixels;  ///< decoded by the scene reader
    int environmentWidth = 0, environmentHeight = 0;
    Real environmentIntensity = 1;
    Real environmentRotation = 0;  ///< degrees
    bool motionBlur = false;
    Real motionBlurShutter = 180;  ///< degrees, (0, 360]
    int motionBlurSamples = 8;     ///< renders a frame, 2..64
    /// Contact highlighting (render.contact): the contact set R as a colour ramp on the surface.
    ContactHighlightMode contactMode = ContactHighlightMode::Off;
    Real contactDepthMax = 0;                  ///< depth at which the ramp reaches `high`; 0: the object's voxel size
    int contactFadeFrames = 12;                ///< recent: frames over which the highlight fades
    bool contactLowSet = false;                ///< whether `low` was given (recent: default the object's colour)
    bool contactHighSet = false;               ///< whether `high` was given (else chosen to contrast with each surface)
    Vec3 contactLow = Vec3(1.0, 0.85, 0.1);    ///< linear RGB: shallow / fading
    Vec3 contactHigh = Vec3(0.9, 0.05, 0.02);  ///< linear RGB: deep / in contact now
    int contactSpread = 4;                     ///< lattice steps the highlight widens over the body (0: R alone)
    bool contactFootprint = true;  ///< also mark the colliders (ground, spheres, meshes, level sets) where touched
    Real contactGlow = 0.35;       ///< the highlight's colour also emitted, times this (reads in shadow)
    /// Overlays (render.overlays): lattice points as dots drawn over the surface (LatticeDotSet).
    /// render.pins: the pinned lattice points drawn as dots (depth-tested).
    bool pins = false;
    Vec3 pinColour = Vec3(0.85, 0.05, 0.75);  ///< linear RGB
    Real pinPointSize = 5;                    ///< dot diameter, output pixels
    bool overlayLattice = false;
    LatticeDotSet overlayLatticeSet = LatticeDotSet::Boundary;
    Vec3 overlayLatticeColour = Vec3(0.05, 0.35, 1.0);  ///< linear RGB
    Real overlayPointSize = 3;                          ///< dot diameter, output pixels
    /// GLN network loops (docs/gln.md) as lines (GlnLoopSet).
    bool overlayGlnLoops = false;
    GlnLoopSet overlayGlnLoopSet = GlnLoopSet::Contact;
    Vec3 overlayGlnColour = Vec3(0.0331, 1.0, 0.1329);  ///< linear RGB (sRGB [0.2, 1, 0.4])
    Real overlayLineWidth = 1.5;                        ///< line width, output pixels
};

struct OutputDesc {
    std::string dir;          ///< absolute; default <cwd>/out/<scene name>; frames <dir>/<name>.####.png (or .exr)
    bool vdb = false;         ///< <dir>/vdb/<name>.####.vdb (docs/vdb.md)
    Real vdbVoxelSize = 0;    ///< world grids' voxel size; 0: the objects' (smallest) voxel size
    bool vdbHalf = false;     ///< density, vel, contact as 16-bit floats
    bool vdbSurface = false;  ///< also the `surface` level set of each deformed mesh
    /// The mesh cache (io/mesh_cache.hpp): "" (none), "ply" or "obj": <dir>/mesh/<object>.####.<ext>.
    std::string mesh;
};

/// How contacts with colliders are found (docs/gln.md, "GLN networks and the contact set R").
struct CollisionDesc {
    enum class Detect { Sdf, Gln };
    Detect detect = Detect::Sdf;  ///< sdf: every point with signed distance < 0; gln: the GLN network's R
    bool coarseToFine = false;    ///< gln: coarse rings first, fine rings only inside linked ones
    /// Deformable objects collide with each other (each one's deformed lattice surface is a
    /// signed-distance collider for the others, rebuilt every substep; sim/body_contact.hpp).
    bool objects = true;
    /// How the distance to another body's surface is taken: Exact, queried point by point
    /// through a hierarchy over the surface's triangles (collide/mesh_distance); Grid, those
    /// exact distances sampled at half the body's voxel where the queries reach and read
    /// trilinearly (collide/sampled_distance), a smoother field at about twice the cost
    /// (docs/gln.md, "Objects colliding").
    enum class Distance { Grid, Exact };
    Distance distance = Distance::Exact;
    Real friction = 0.5;   ///< between objects: 0 slip .. 1 stick
    Real restitution = 0;  ///< between objects: 0..1
};

struct SceneDesc {
    std::string path;  ///< the scene file
    std::string name;  ///< default: the file name without .json
    int frameStart = 1;
    int frameEnd = 1;
    Real fps = 24;
    int substeps = 1;
    /// Adaptive substeps (Simulation::frameSubsteps): each frame takes between `substeps` and
    /// `maxSubsteps`, enough that no point moves more than `cfl` lattice spacings in one substep
    /// (nor a fifth of that from rest under the force), that δt √stiffness ≤ 1 and that the
    /// twist stays within half its limiter. maxSubsteps = substeps: a fixed count.
    int maxSubsteps = 16;
    bool maxSubstepsGiven = false;  ///< the scene sets max_substeps: a stiff body never raises it (Simulation)
    Real cfl = 1;
    std::vector<ObjectDesc> objects;
    std::vector<ForceTerm>
        forces;  ///< the field's terms as the file gives them (io/scene_json); the field: sim/forces_from_scene
    std::vector<ColliderDesc> colliders;
    CollisionDesc collision;
    std::vector<CurveDesc> curves;  ///< closed curves (GLN figures); a scene has objects or curves
    GlnFigureDesc gln;
    CameraDesc camera;
    RenderDesc render;
    OutputDesc output;
};

/// Whether the scene's bodies move: a force, or a deformable object's initial velocity or spin
/// (what decides whether a shot is simulated: io/scene_build, view/frame_view's floor).
bool sceneMoves(const SceneDesc& scene);

}  // namespace dgv
