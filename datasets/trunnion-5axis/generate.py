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
import struct

L, W, H = 110.0, 70.0, 30.0          # block
R = 30.0                             # dome sphere radius
CX, CY = 30.0, 0.0                   # dome axis, part frame (origin at the bottom face's centre)
BASE = math.radians(50.0)            # the cap ends where the surface leans 50 deg
CZ = H - R * math.cos(BASE)          # sphere centre height
RB = R * math.sin(BASE)              # base circle radius on the top face
TOOL_R = 3.0
CAM = (L / 2, W / 2, -H)             # CAM coordinates = part coordinates + CAM


def mesh():
    """Closed triangle mesh of the block with the dome, part frame."""
    tris = []
    n = 96
    circle = [(CX + RB * math.cos(2 * math.pi * k / n), CY + RB * math.sin(2 * math.pi * k / n)) for k in range(n)]
    # Outer boundary of the top face: the rectangle's corners and the points where rays from the
    # dome's axis through the circle's points meet it, in order of angle about the dome's axis.
    def ray_hit(a):
        dx, dy = math.cos(a), math.sin(a)
        best = None
        for t in [(L / 2 - CX) / dx if dx > 1e-12 else None, (-L / 2 - CX) / dx if dx < -1e-12 else None,
                  (W / 2 - CY) / dy if dy > 1e-12 else None, (-W / 2 - CY) / dy if dy < -1e-12 else None]:
            if t is not None and t > 0:
                x, y = CX + t * dx, CY + t * dy
                if -L / 2 - 1e-9 <= x <= L / 2 + 1e-9 and -W / 2 - 1e-9 <= y <= W / 2 + 1e-9:
                    best = t if best is None or t < best else best
        return (CX + best * dx, CY + best * dy)
    outer = [(math.atan2(p[1] - CY, p[0] - CX) % (2 * math.pi), p) for p in
             [ray_hit(2 * math.pi * k / n) for k in range(n)]]
    for c in [(L / 2, W / 2), (-L / 2, W / 2), (-L / 2, -W / 2), (L / 2, -W / 2)]:
        outer.append((math.atan2(c[1] - CY, c[0] - CX) % (2 * math.pi), c))
    outer.sort()
    inner = [(2 * math.pi * k / n, circle[k]) for k in range(n)]
    # Annulus between the two angular sequences (counter-clockwise seen from above: normal up).
    i = j = 0
    top = lambda p: (p[0], p[1], H)
    while i < len(inner) or j < len(outer):
        ai = inner[i % len(inner)][0] + (2 * math.pi if i >= len(inner) else 0)
        aj = outer[j % len(outer)][0] + (2 * math.pi if j >= len(outer) else 0)
        a, b = inner[i % len(inner)][1], outer[j % len(outer)][1]
        if (ai <= aj and i < len(inner)) or j >= len(outer):
            c = inner[(i + 1) % len(inner)][1]
            tris.append((top(a), top(b), top(c)))
            i += 1
        else:
            c = outer[(j + 1) % len(outer)][1]
            tris.append((top(a), top(b), top(c)))
            j += 1
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
    # Sides: each side fans from its bottom corners to the top boundary points on that side.
    ring_pts = [p for _, p in outer]
    def side(sel, key, reverse):
        pts = sorted([p for p in ring_pts if sel(p)], key=key, reverse=reverse)
        a, b = pts[0], pts[-1]
        for k in range(len(pts) - 1):
            tris.append(((pts[k][0], pts[k][1], H), (pts[k][0], pts[k][1], 0.0), (pts[k + 1][0], pts[k + 1][1], H)))
            tris.append(((pts[k + 1][0], pts[k + 1][1], H), (pts[k][0], pts[k][1], 0.0), (pts[k + 1][0], pts[k + 1][1], 0.0)))
        return a, b
    eps = 1e-9
    side(lambda p: abs(p[0] - L / 2) < eps, lambda p: p[1], False)    # +x face, y rising
    side(lambda p: abs(p[1] - W / 2) < eps, lambda p: -p[0], False)   # +y face, x falling
    side(lambda p: abs(p[0] + L / 2) < eps, lambda p: -p[1], False)   # -x face, y falling
    side(lambda p: abs(p[1] + W / 2) < eps, lambda p: p[0], False)    # -y face, x rising
    # Bottom: a fan from its centre to the same boundary points as the sides, normal down.
    for k in range(len(ring_pts)):
        a, b = ring_pts[k], ring_pts[(k + 1) % len(ring_pts)]
        tris.append(((0.0, 0.0, 0.0), (b[0], b[1], 0.0), (a[0], a[1], 0.0)))
    return tris


def write_stl(path, tris):
    with open(path, 'wb') as f:
        f.write(b'machplan trunnion-5axis part (generate.py)'.ljust(80, b' '))
        f.write(struct.pack('<I', len(tris)))
        for t in tris:
            (ax, ay, az), (bx, by, bz), (cx, cy, cz) = [(p[0] + CAM[0], p[1] + CAM[1], p[2] + CAM[2]) for p in t]
            ux, uy, uz = bx - ax, by - ay, bz - az
            vx, vy, vz = cx - ax, cy - ay, cz - az
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            ln = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
            f.write(struct.pack('<12fH', nx / ln, ny / ln, nz / ln, ax, ay, az, bx, by, bz, cx, cy, cz, 0))


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
        segment = []
        for x in xs + [None]:
            if x is not None and math.hypot(x - CX, y - CY) >= keep_out:
                segment.append(x)
                continue
            if segment:
                out.append((*cam(segment[0], y, safe), 0, 0, 1, True, 0))
                for sx in segment:
                    out.append((*cam(sx, y, H), 0, 0, 1, False, 1200))
                out.append((*cam(segment[-1], y, safe), 0, 0, 1, True, 0))
                segment = []
        y += 3.0
        row += 1
    # 2. the dome, from its base up, tool along the normal.
    first = True
    polar = BASE
    while polar > 0.5 * math.radians(1.5):
        for k in range(180):
            lon = 2 * math.pi * k / 180
            n = (math.sin(polar) * math.cos(lon), math.sin(polar) * math.sin(lon), math.cos(polar))
            p = (CX + R * n[0], CY + R * n[1], CZ + R * n[2])
            if first:
                out.append((*cam(p[0] + 25 * n[0], p[1] + 25 * n[1], p[2] + 25 * n[2]), *n, True, 0))
                first = False
            out.append((*cam(*p), *n, False, 900))
        polar -= math.radians(1.5)
    apex = (CX, CY, CZ + R)
    out.append((*cam(*apex), 0, 0, 1, False, 900))
    out.append((*cam(apex[0], apex[1], safe), 0, 0, 1, True, 0))
    return out


def write_apt(path, poses):
    with open(path, 'w') as f:
        f.write('PARTNO/TRUNNION DOME BLOCK (machplan generate.py)\n')
        f.write('UNITS/MM\n')
        f.write('CUTTER/6,3\n')
        f.write('MULTAX/ON\n')
        feed = None
        for x, y, z, i, j, k, rapid, fr in poses:
            if rapid:
                f.write('RAPID\n')
            elif fr != feed:
                f.write(f'FEDRAT/MMPM,{fr:.0f}\n')
                feed = fr
            f.write(f'GOTO/{x:.4f},{y:.4f},{z:.4f},{i:.6f},{j:.6f},{k:.6f}\n')
        f.write('FINI\n')


if __name__ == '__main__':
    write_stl('part.stl', mesh())
    write_apt('part.apt', toolpath())
