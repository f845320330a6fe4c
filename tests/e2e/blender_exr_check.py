# Opens a dgv EXR frame in Blender (headless) as a compositor would: loads it as an image, puts
# it in an Image node of the compositor, and prints what Blender sees:
#
#   blender -b --factory-startup -noaudio --python-exit-code 1 -P blender_exr_check.py -- FRAME.exr X,Y ...
#
# Prints "size W H float FLOAT alpha ALPHA_MODE", "outputs NAME ..." (the Image node's enabled
# sockets: Depth appears for a file with a Z channel) and, for each X,Y (pixels, top row 0),
# "pixel X Y R G B A" as Blender holds it. Exits 1 when the file does not load as a float image.
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
image = bpy.data.images.load(args[0])
width, height = image.size
if not image.is_float or width == 0:
    print("blender: %s did not load as a float image" % args[0])
    sys.exit(1)
print("size %d %d float %d alpha %s" % (width, height, image.is_float, image.alpha_mode))
scene = bpy.context.scene
scene.use_nodes = True
node = scene.node_tree.nodes.new("CompositorNodeImage")
node.image = image
print("outputs " + " ".join(o.name for o in node.outputs if o.enabled))
pixels = image.pixels[:]  # bottom row first
for xy in args[1:]:
    x, y = (int(v) for v in xy.split(","))
    i = ((height - 1 - y) * width + x) * 4
    print("pixel %d %d %.9g %.9g %.9g %.9g" % ((x, y) + tuple(pixels[i:i + 4])))
