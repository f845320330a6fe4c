#!/usr/bin/env python3
"""Writes scenes/meshes/trefoil.ply: a closed tube around a trefoil knot, binary little-endian PLY.

The tube follows r(t) = (sin t + 2 sin 2t, cos t - 2 cos 2t, -sin 3t) / 3, with a rotation-
minimising (parallel-transport) frame whose closing twist is spread evenly along the curve, so the
mesh closes without a seam. Outward normals, shared vertices: closed and manifold.
Usage: scripts/make_trefoil.py [OUT] [SEGMENTS] [SIDES] [TUBE_RADIUS]
"""
import math
import struct
import sys


def curve(t):
    return ((math.sin(t) + 2 * math.sin(2 * t)) / 3,
            (math.cos(t) - 2 * math.cos(2 * t)) / 3,
            -math.sin(3 * t) / 3)


def sub(a, b): return tuple(x - y for x, y in zip(a, b))
def add(a, b): return tuple(x + y for x, y in zip(a, b))
def mul(a, s): return tuple(x * s for x in a)
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
def norm(a):
    n = math.sqrt(dot(a, a))
    return mul(a, 1 / n)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/meshes/trefoil.ply"
    segs = int(sys.argv[2]) if len(sys.argv) > 2 else 384
    sides = int(sys.argv[3]) if len(sys.argv) > 3 else 24
    radius = float(sys.argv[4]) if len(sys.argv) > 4 else 0.17
    ts = [2 * math.pi * i / segs for i in range(segs)]
    pts = [curve(t) for t in ts]
    tangents = [norm(sub(pts[(i + 1) % segs], pts[i - 1])) for i in range(segs)]
    # parallel transport of a normal around the loop
    n0 = norm(cross(tangents[0], (0.0, 0.0, 1.0)))
    normals = [n0]
    for i in range(1, segs + 1):
        t_prev, t_cur = tangents[i - 1], tangents[i % segs]
        n = normals[-1]
        n = norm(sub(n, mul(t_cur, dot(n, t_cur))))
        normals.append(n)
    # closing twist: angle from the transported normal back to n0, spread along the loop
    nend = normals[segs]
    b0 = cross(tangents[0], n0)
    twist = math.atan2(dot(nend, b0), dot(nend, n0))
    verts = []
    for i in range(segs):
        t = tangents[i]
        n = normals[i]
        b = cross(t, n)
        a = -twist * i / segs
        n, b = add(mul(n, math.cos(a)), mul(b, math.sin(a))), sub(mul(b, math.cos(a)), mul(n, math.sin(a)))
        for j in range(sides):
            phi = 2 * math.pi * j / sides
            off = add(mul(n, math.cos(phi) * radius), mul(b, math.sin(phi) * radius))
            verts.append(add(pts[i], off))
    faces = []
    for i in range(segs):
        i2 = (i + 1) % segs
        for j in range(sides):
            j2 = (j + 1) % sides
            a, b_, c, d = i * sides + j, i2 * sides + j, i2 * sides + j2, i * sides + j2
            faces.append((a, b_, c))
            faces.append((a, c, d))
    # orient outward: signed volume must be positive
    vol = sum(dot(verts[f[0]], cross(verts[f[1]], verts[f[2]])) for f in faces) / 6
    if vol < 0:
        faces = [(f[0], f[2], f[1]) for f in faces]
    header = ("ply\nformat binary_little_endian 1.0\ncomment trefoil knot tube, scripts/make_trefoil.py\n"
              f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(out, "wb") as f:
        f.write(header.encode("ascii"))
        for v in verts:
            f.write(struct.pack("<3f", *v))
        for fc in faces:
            f.write(struct.pack("<B3i", 3, *fc))
    print(f"{out}: {len(verts)} vertices, {len(faces)} triangles, volume {abs(vol):.5f}")


if __name__ == "__main__":
    main()
