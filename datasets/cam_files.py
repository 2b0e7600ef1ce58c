"""What the datasets' generate.py scripts share (trunnion-5axis, multi-tool, wei-lee-2020): the
top face of a plate with a star-shaped opening, the plate's sides and bottom, the STL and
APT/CLDATA writers, and the dome block that trunnion-5axis draws and multi-tool machines again
(its sizes, its facing rows and its dome's rings). Standard library only; deterministic.
"""
import math
import struct


# The dome block (trunnion-5axis/part.stl): a 110 x 70 x 30 mm block with a spherical dome (a cap
# of a 30 mm sphere, cut where its surface leans 50 deg) whose axis stands 30 mm off the block's
# centre along x; part frame: origin at the bottom face's centre. CAM coordinates = part + CAM.
class DomeBlock:
    L, W, H = 110.0, 70.0, 30.0          # block
    R = 30.0                             # dome sphere radius
    CX, CY = 30.0, 0.0                   # dome axis
    BASE = math.radians(50.0)            # the cap ends where the surface leans 50 deg
    CZ = H - R * math.cos(BASE)          # sphere centre height
    RB = R * math.sin(BASE)              # base circle radius on the top face
    CAM = (L / 2, W / 2, -H)             # the CAM zero on the top face at the stock's corner


def outside_circle(xs, y, cx, cy, keep_out):
    """The stretches of the row (x in xs, at y) that stay `keep_out` or more from (cx, cy), in
    order: a facing pass split around the dome."""
    seg = []
    for x in xs + [None]:
        if x is not None and math.hypot(x - cx, y - cy) >= keep_out:
            seg.append(x)
            continue
        if seg:
            yield seg
            seg = []


def dome_rings(b, step, per_ring):
    """(point, normal) on the dome of DomeBlock-like `b`, ring of latitude by ring from its base
    up to near the apex, `step` rad apart, `per_ring` points each."""
    polar = b.BASE
    while polar > 0.5 * step:
        for k in range(per_ring):
            lon = 2 * math.pi * k / per_ring
            n = (math.sin(polar) * math.cos(lon), math.sin(polar) * math.sin(lon), math.cos(polar))
            yield (b.CX + b.R * n[0], b.CY + b.R * n[1], b.CZ + b.R * n[2]), n
        polar -= step


def plate_top(L, W, H, cx, cy, inner):
    """Triangles of the top face (z = H) of an L x W plate centred on the origin, outside an
    opening whose boundary `inner` is star-shaped about (cx, cy): (angle about (cx, cy), (x, y))
    pairs, counter-clockwise from angle 0. Returns the triangles (normal up) and the plate's
    boundary points on its edge, in order of angle about (cx, cy): rays from (cx, cy) through
    the opening's points, and the corners."""
    def ray_hit(a):
        dx, dy = math.cos(a), math.sin(a)
        best = None
        for t in [(L / 2 - cx) / dx if dx > 1e-12 else None, (-L / 2 - cx) / dx if dx < -1e-12 else None,
                  (W / 2 - cy) / dy if dy > 1e-12 else None, (-W / 2 - cy) / dy if dy < -1e-12 else None]:
            if t is not None and t > 0:
                x, y = cx + t * dx, cy + t * dy
                if -L / 2 - 1e-9 <= x <= L / 2 + 1e-9 and -W / 2 - 1e-9 <= y <= W / 2 + 1e-9:
                    best = t if best is None or t < best else best
        return (cx + best * dx, cy + best * dy)
    outer = [(math.atan2(p[1] - cy, p[0] - cx) % (2 * math.pi), p) for p in [ray_hit(a) for a, _ in inner]]
    for c in [(L / 2, W / 2), (-L / 2, W / 2), (-L / 2, -W / 2), (L / 2, -W / 2)]:
        outer.append((math.atan2(c[1] - cy, c[0] - cx) % (2 * math.pi), c))
    outer.sort()
    # Annulus between the two angular sequences (counter-clockwise seen from above: normal up).
    tris = []
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
    return tris, [p for _, p in outer]


def plate_sides_and_bottom(L, W, H, ring_pts):
    """The plate's four sides, each fanned from the bottom to its edge points in `ring_pts`, and
    its bottom (z = 0), a fan from the centre over the same points (normals outward)."""
    tris = []

    def side(sel, key):
        pts = sorted([p for p in ring_pts if sel(p)], key=key)
        for k in range(len(pts) - 1):
            tris.append(((pts[k][0], pts[k][1], H), (pts[k][0], pts[k][1], 0.0), (pts[k + 1][0], pts[k + 1][1], H)))
            tris.append(((pts[k + 1][0], pts[k + 1][1], H), (pts[k][0], pts[k][1], 0.0), (pts[k + 1][0], pts[k + 1][1], 0.0)))
    eps = 1e-9
    side(lambda p: abs(p[0] - L / 2) < eps, lambda p: p[1])     # +x face, y rising
    side(lambda p: abs(p[1] - W / 2) < eps, lambda p: -p[0])    # +y face, x falling
    side(lambda p: abs(p[0] + L / 2) < eps, lambda p: -p[1])    # -x face, y falling
    side(lambda p: abs(p[1] + W / 2) < eps, lambda p: p[0])     # -y face, x rising
    for k in range(len(ring_pts)):
        a, b = ring_pts[k], ring_pts[(k + 1) % len(ring_pts)]
        tris.append(((0.0, 0.0, 0.0), (b[0], b[1], 0.0), (a[0], a[1], 0.0)))
    return tris


def write_stl(path, tris, header, cam):
    """Binary STL of `tris` (part frame) moved by `cam` into CAM coordinates."""
    with open(path, 'wb') as f:
        f.write(header.encode().ljust(80, b' '))
        f.write(struct.pack('<I', len(tris)))
        for t in tris:
            (ax, ay, az), (bx, by, bz), (cx, cy, cz) = [(p[0] + cam[0], p[1] + cam[1], p[2] + cam[2]) for p in t]
            ux, uy, uz = bx - ax, by - ay, bz - az
            vx, vy, vz = cx - ax, cy - ay, cz - az
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            ln = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
            f.write(struct.pack('<12fH', nx / ln, ny / ln, nz / ln, ax, ay, az, bx, by, bz, cx, cy, cz, 0))


def write_apt(path, poses, partno, cutter='6,3'):
    """APT/CLDATA of `poses`: (x, y, z, i, j, k, rapid, feed in mm/min) in CAM coordinates."""
    with open(path, 'w') as f:
        f.write(f'PARTNO/{partno}\n')
        f.write('UNITS/MM\n')
        f.write(f'CUTTER/{cutter}\n')
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
