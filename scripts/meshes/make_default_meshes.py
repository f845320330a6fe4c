#!/usr/bin/env python3
"""Writes the default scene's meshes (scenes/default.json): a fluted jelly mould and a serving plate.

    python3 scripts/meshes/make_default_meshes.py   # writes scenes/meshes/jelly_mould.obj, plate.obj

Both are closed, consistently oriented (counter-clockwise seen from outside) surfaces of
revolution about +y, standing on y = 0, in metres.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, '..', '..', 'scenes', 'meshes')


def revolve(profile, segments, flutes=0, flute_depth=0.0):
    """profile: (r, y) from the bottom centre's ring outwards and up to the top; the first and last
    points sit on the axis (r = 0). Returns vertices and triangles."""
    verts, tris = [], []
    bottom = len(verts)
    verts.append((0.0, profile[0][1], 0.0))
    rings = []
    for r, y in profile[1:-1]:
        ring = []
        for s in range(segments):
            a = 2 * math.pi * s / segments
            k = 1 + flute_depth * math.cos(flutes * a) if flutes else 1
            ring.append(len(verts))
            verts.append((r * k * math.cos(a), y, -r * k * math.sin(a)))
        rings.append(ring)
    top = len(verts)
    verts.append((0.0, profile[-1][1], 0.0))
    n = segments
    # Angles run counter-clockwise seen from +y (x towards -z), so the outward winding is:
    for s in range(n):  # bottom cap, seen from below
        tris.append((bottom, rings[0][(s + 1) % n], rings[0][s]))
    for lo, hi in zip(rings, rings[1:]):
        for s in range(n):
            a, b, c, d = lo[s], lo[(s + 1) % n], hi[(s + 1) % n], hi[s]
            tris.append((a, b, c))
            tris.append((a, c, d))
    for s in range(n):  # top cap, seen from above
        tris.append((top, rings[-1][s], rings[-1][(s + 1) % n]))
    return verts, tris


def write_obj(path, verts, tris, comment):
    with open(path, 'w') as f:
        f.write('# ' + comment + '\n')
        for v in verts:
            f.write('v %.6f %.6f %.6f\n' % v)
        for t in tris:
            f.write('f %d %d %d\n' % (t[0] + 1, t[1] + 1, t[2] + 1))


def mould_profile():
    """A two-tier jelly mould: a wide lower tier, a waist, a narrower upper tier, a domed top."""
    H = 0.40
    pts = [(0.0, 0.0)]
    rows = 40
    for i in range(rows + 1):
        t = i / rows
        y = H * t
        r = 0.27 - 0.09 * t                                   # the taper
        r += 0.025 * math.cos(2 * math.pi * t) - 0.025         # the waist between the tiers
        r *= 1 - 0.12 * t ** 6                                  # the shoulder into the dome
        if i == 0:
            r -= 0.01                                           # a rounded foot
        pts.append((r, y))
    for i in range(1, 7):  # the dome
        a = (math.pi / 2) * i / 7
        pts.append((pts[-1 - (i - 1)][0] * math.cos(a) if i == 1 else pts[rows + 1][0] * math.cos(a),
                    H + 0.06 * math.sin(a)))
    pts.append((0.0, H + 0.06))
    return pts


def plate_profile():
    R, h = 0.44, 0.10
    return [(0.0, 0.0), (R - 0.03, 0.0), (R, 0.03), (R, h - 0.02), (R - 0.02, h), (0.0, h)]


if __name__ == '__main__':
    v, t = revolve(mould_profile(), 96, flutes=10, flute_depth=0.06)
    write_obj(os.path.join(OUT, 'jelly_mould.obj'), v, t,
              'a fluted two-tier jelly mould, 0.54 m across and 0.46 m tall (scripts/meshes/make_default_meshes.py)')
    v, t = revolve(plate_profile(), 96)
    write_obj(os.path.join(OUT, 'plate.obj'), v, t,
              'a serving plate, 0.88 m across and 10 cm thick (scripts/meshes/make_default_meshes.py)')
