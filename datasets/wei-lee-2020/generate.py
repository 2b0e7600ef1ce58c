#!/usr/bin/env python3
"""Writes part.stl and part.apt for the Wei and Lee style case (scene.yaml; see README.md).

The part (RECONSTRUCTED): a 160 x 120 x 30 mm plate with a closed channel milled into its top
face around an island, the channel off the plate's centre as a seal groove around a port near
one end of a manifold plate would be. The channel's centreline is a rounded rectangle 60 x 40 mm
(corner radius 10 mm) centred 40 mm along x and 25 mm along y from the plate's centre; the
channel is 8 mm wide at the bottom and 8 mm deep, its inner wall vertical and its outer wall
drafted 15 deg outward.

The tool path (RECONSTRUCTED), as a CAM system would export it for a 6 mm ball end mill with
the CAM zero on the top face at the stock's corner (x 0 .. 160, y 0 .. 120, z -30 .. 0): four
passes 2 mm apart down to the channel's bottom, each a full loop with the tool leaning 15 deg
outward, its flank along the drafted outer wall (a 5-axis strategy: the tool's lean turns with
the channel, so the rotary table turns once per loop). A pose every 1 mm on the straight
sides and every 2 deg on the corners; 1000 mm/min along the channel, 300 mm/min plunging.

Standard library only; the output is deterministic. Run from this folder.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import cam_files  # noqa: E402  (datasets/cam_files.py: shared with the other datasets' scripts)

L, W, H = 160.0, 120.0, 30.0          # plate
CX, CY = 40.0, 25.0                   # channel centre, part frame (origin at the bottom face's centre)
A, B, RC = 30.0, 20.0, 10.0           # centreline half sizes and corner radius
HALF = 4.0                            # half the channel's width at its bottom
DEPTH = 8.0
DRAFT = math.radians(15.0)            # outer wall draft = the tool's lean
TOOL_R = 3.0
CAM = (L / 2, W / 2, -H)              # CAM coordinates = part coordinates + CAM


def centreline(n_corner=45, step=1.0):
    """(point, outward normal) around the centreline, counter-clockwise from its rightmost middle point."""
    out = []
    sides = [  # straight part: start, direction, length; then the corner's centre and start angle
        ((CX + A, CY - (B - RC)), (0.0, 1.0), 2 * (B - RC), (CX + A - RC, CY + B - RC), 0.0),
        ((CX + A - RC, CY + B), (-1.0, 0.0), 2 * (A - RC), (CX - A + RC, CY + B - RC), math.pi / 2),
        ((CX - A, CY + B - RC), (0.0, -1.0), 2 * (B - RC), (CX - A + RC, CY - B + RC), math.pi),
        ((CX - A + RC, CY - B), (1.0, 0.0), 2 * (A - RC), (CX + A - RC, CY - B + RC), 3 * math.pi / 2),
    ]
    for k, (start, d, length, centre, a0) in enumerate(sides):
        # The first side starts half way: the loop starts at the rightmost middle point.
        s0 = length / 2 if k == 0 else 0.0
        count = max(1, int(round((length - s0) / step)))
        for i in range(count):
            s = s0 + (length - s0) * i / count
            out.append(((start[0] + d[0] * s, start[1] + d[1] * s), (d[1], -d[0])))
        for i in range(n_corner):
            a = a0 + (math.pi / 2) * i / n_corner
            out.append(((centre[0] + RC * math.cos(a), centre[1] + RC * math.sin(a)), (math.cos(a), math.sin(a))))
    # The last side's second half, back to the start.
    start, d, length = sides[0][0], sides[0][1], sides[0][2]
    count = int(round(length / 2 / step))
    for i in range(count):
        s = length / 2 * i / count
        out.append(((start[0] + d[0] * s, start[1] + d[1] * s), (d[1], -d[0])))
    return out


def offset(line, off, z):
    return [(p[0] + off * n[0], p[1] + off * n[1], z) for p, n in line]


def mesh():
    """Closed triangle mesh of the plate with its channel, part frame."""
    tris = []
    line = centreline()
    m = len(line)
    bottom = H - DEPTH
    it, ib = offset(line, -HALF, H), offset(line, -HALF, bottom)           # inner (island) wall
    ob, ot = offset(line, HALF, bottom), offset(line, HALF + DEPTH * math.tan(DRAFT), H)  # outer wall
    for k in range(m):
        j = (k + 1) % m
        tris.append(((CX, CY, H), it[k], it[j]))                                   # island top
        tris += [(ib[k], ib[j], it[j]), (ib[k], it[j], it[k])]                      # island wall
        tris += [(ib[k], ob[k], ob[j]), (ib[k], ob[j], ib[j])]                      # channel bottom
        tris += [(ob[k], ot[k], ot[j]), (ob[k], ot[j], ob[j])]                      # drafted outer wall

    # The plate's top face around the channel (star-shaped about its centre), its sides and bottom.
    angle = lambda p: math.atan2(p[1] - CY, p[0] - CX) % (2 * math.pi)
    inner = [(angle(p), p) for p in ot]
    inner[0] = (0.0, inner[0][1])
    face, ring_pts = cam_files.plate_top(L, W, H, CX, CY, inner)
    tris += face
    tris += cam_files.plate_sides_and_bottom(L, W, H, ring_pts)
    return tris


def toolpath():
    """(x, y, z, i, j, k, rapid, feed) in CAM coordinates."""
    out = []
    line = centreline()
    lean = lambda n: (math.sin(DRAFT) * n[0], math.sin(DRAFT) * n[1], math.cos(DRAFT))
    cam = lambda p: (p[0] + CAM[0], p[1] + CAM[1], p[2] + CAM[2])
    for depth in (2.0, 4.0, 6.0, 8.0):
        # The ball's tip on a line 3 mm (the radius) inside the drafted outer wall at this depth.
        off = HALF + (DEPTH - depth) * math.tan(DRAFT) - TOOL_R
        pts = [((p[0] + off * n[0], p[1] + off * n[1], H - depth), lean(n)) for p, n in line]
        pts.append(pts[0])
        p0, a0 = pts[0]
        if depth == 2.0:  # approach along the tool's axis from 25 mm above the start
            out.append((*cam((p0[0] + 25 * a0[0], p0[1] + 25 * a0[1], p0[2] + 25 * a0[2])), *a0, True, 0))
        out.append((*cam(p0), *a0, False, 300))
        for p, a in pts[1:]:
            out.append((*cam(p), *a, False, 1000))
    p, a = pts[-1]
    out.append((*cam((p[0] + 25 * a[0], p[1] + 25 * a[1], p[2] + 25 * a[2])), *a, True, 0))
    return out


if __name__ == '__main__':
    cam_files.write_stl('part.stl', mesh(), 'machplan wei-lee-2020 channel plate (generate.py)', CAM)
    cam_files.write_apt('part.apt', toolpath(), 'CHANNEL PLATE (machplan generate.py)')
