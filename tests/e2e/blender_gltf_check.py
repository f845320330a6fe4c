# Imports a dgv shot's glTF in Blender (headless) and checks one object at one frame against the
# mesh cache's PLY file of that frame: the vertex count, every vertex position with the shape
# keys' and the scale's animation evaluated at that frame, and that the object's other segments
# (OBJECT.2, OBJECT.3, ...: a re-parametrised goo body's other triangles) are hidden then.
#
#   blender -b --factory-startup -noaudio --python-exit-code 1 -P blender_gltf_check.py -- \
#       SHOT.glb OBJECT FRAME FRAME.ply TOLERANCE
#
# Prints "blender: OBJECT frame FRAME: N vertices, max error E" and exits 0, or exits 1 naming
# what differs.
import struct
import sys

import numpy

# Blender 3.4's glTF importer uses numpy.bool, which Debian 12's NumPy 1.24 no longer has.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

import bpy  # noqa: E402


def fail(msg):
    print("blender: " + msg)
    sys.exit(1)


def read_ply_positions(path):
    """The x y z of each vertex of a dgv mesh cache PLY (io/mesh_cache.cpp's layout)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    count = 0
    for line in data[:end].decode("ascii").splitlines():
        if line.startswith("element vertex "):
            count = int(line.split()[2])
    stride = 6 * 4 + 3 + 4
    return [struct.unpack_from("<3f", data, end + v * stride) for v in range(count)]


glb, name, frame, ply, tol = sys.argv[sys.argv.index("--") + 1:]
frame, tol = int(frame), float(tol)

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
obj = bpy.data.objects.get(name)
if obj is None or obj.type != "MESH":
    fail("no mesh object '%s' in %s (objects: %s)" % (name, glb, [o.name for o in bpy.data.objects]))
if obj.data.shape_keys is None or obj.data.shape_keys.animation_data is None:
    fail("'%s' has no animated shape keys" % name)

want = read_ply_positions(ply)
if len(obj.data.vertices) != len(want):
    fail("'%s' has %d vertices, the PLY %d" % (name, len(obj.data.vertices), len(want)))

scene = bpy.context.scene
scene.frame_set(frame)
depsgraph = bpy.context.evaluated_depsgraph_get()
mesh = obj.evaluated_get(depsgraph).to_mesh()
world = obj.matrix_world
err = 0.0
for v, (x, y, z) in zip(mesh.vertices, want):
    p = world @ v.co
    # glTF (and dgv) are +y up; Blender is +z up: (x, y, z) -> (x, -z, y).
    err = max(err, abs(p.x - x), abs(p.y + z), abs(p.z - y))
for other in bpy.data.objects:
    if other is not obj and other.name.startswith(name + ".") and other.matrix_world.to_scale().length > 0:
        fail("'%s' is shown at frame %d beside '%s'" % (other.name, frame, name))
print("blender: %s frame %d: %d vertices, max error %.3g" % (name, frame, len(want), err))
if not err <= tol:
    fail("'%s' at frame %d is %.3g m from the PLY (tolerance %g)" % (name, frame, err, tol))
