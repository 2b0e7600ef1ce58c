#!/usr/bin/env python3
"""Writes part.stl and part.apt for the bundled 5-axis trunnion scene (scene.yaml).

The part: a 110 x 70 x 30 mm block with a spherical dome (a cap of a 30 mm sphere, cut where
its surface leans 50 deg from vertical) standing on the top face 30 mm off the block's centre
along x. The tool path, as a CAM system would export it for a 6 mm ball end mill, with the CAM
zero on the top face at the stock's corner (x 0 .. 110, y 0 .. 70, z -30 .. 12.8):

  1. facing the top face around the dome, tool vertical, 3 mm step-over (3-axis);
  2. finishing the dome, tool along the surface normal, rings of latitude from the base up
     to the apex, 1.5 deg apart, a pose every 2 deg of longitude (5-axis).

Standard library only; the output is deterministic. Run from this folder.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import cam_files  # noqa: E402  (datasets/cam_files.py: shared with the other datasets' scripts)

B = cam_files.DomeBlock               # the part's sizes (datasets/cam_files.py)
L, W, H, R, CX, CY, BASE, CZ, RB, CAM = B.L, B.W, B.H, B.R, B.CX, B.CY, B.BASE, B.CZ, B.RB, B.CAM
TOOL_R = 3.0


def mesh():
    """Closed triangle mesh of the block with the dome, part frame."""
    tris = []
    n = 96
    circle = [(CX + RB * math.cos(2 * math.pi * k / n), CY + RB * math.sin(2 * math.pi * k / n)) for k in range(n)]
    # The top face around the dome's base circle (cam_files.plate_top: the rectangle's corners and
    # the points where rays from the dome's axis through the circle's points meet it).
    face, ring_pts = cam_files.plate_top(L, W, H, CX, CY, [(2 * math.pi * k / n, circle[k]) for k in range(n)])
    tris += face
    top = lambda p: (p[0], p[1], H)
    # Dome: rings of latitude from the base up, the apex last.
    m = 24
    rings = []
    for r in range(m + 1):
        polar = BASE * (1 - r / m)
        rings.append([(CX + R * math.sin(polar) * math.cos(2 * math.pi * k / n),
                       CY + R * math.sin(polar) * math.sin(2 * math.pi * k / n),
                       CZ + R * math.cos(polar)) for k in range(n)])
    rings[0] = [top(p) for p in circle]
    for r in range(m - 1):
        for k in range(n):
            a, b = rings[r][k], rings[r][(k + 1) % n]
            c, d = rings[r + 1][k], rings[r + 1][(k + 1) % n]
            tris.append((a, b, d))
            tris.append((a, d, c))
    apex = (CX, CY, CZ + R)
    for k in range(n):
        tris.append((rings[m - 1][k], rings[m - 1][(k + 1) % n], apex))
    # Sides and bottom (cam_files.plate_sides_and_bottom).
    tris += cam_files.plate_sides_and_bottom(L, W, H, ring_pts)
    return tris


def toolpath():
    """(x, y, z, i, j, k, rapid, feed) in CAM coordinates."""
    out = []
    def cam(x, y, z):
        return (x + CAM[0], y + CAM[1], z + CAM[2])
    safe = H + 25
    # 1. facing around the dome, rows along x, 3 mm apart.
    keep_out = RB + TOOL_R + 1.0
    row = 0
    y = -W / 2 + TOOL_R
    while y <= W / 2 - TOOL_R + 1e-9:
        xs = [-L / 2 + TOOL_R + 2.0 * k for k in range(int((L - 2 * TOOL_R) / 2.0) + 1)]
        if row % 2:
            xs.reverse()
        for segment in cam_files.outside_circle(xs, y, CX, CY, keep_out):
            out.append((*cam(segment[0], y, safe), 0, 0, 1, True, 0))
            for sx in segment:
                out.append((*cam(sx, y, H), 0, 0, 1, False, 1200))
            out.append((*cam(segment[-1], y, safe), 0, 0, 1, True, 0))
        y += 3.0
        row += 1
    # 2. the dome, from its base up, tool along the normal.
    first = True
    for p, n in cam_files.dome_rings(B, math.radians(1.5), 180):
        if first:
            out.append((*cam(p[0] + 25 * n[0], p[1] + 25 * n[1], p[2] + 25 * n[2]), *n, True, 0))
            first = False
        out.append((*cam(*p), *n, False, 900))
    apex = (CX, CY, CZ + R)
    out.append((*cam(*apex), 0, 0, 1, False, 900))
    out.append((*cam(apex[0], apex[1], safe), 0, 0, 1, True, 0))
    return out


if __name__ == '__main__':
    cam_files.write_stl('part.stl', mesh(), 'machplan trunnion-5axis part (generate.py)', CAM)
    cam_files.write_apt('part.apt', toolpath(), 'TRUNNION DOME BLOCK (machplan generate.py)')
