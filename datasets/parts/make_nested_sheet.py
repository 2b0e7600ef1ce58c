#!/usr/bin/env python3
"""Writes nested_sheet.ngc: a plasma sheet of 14 parts nested on 1030 x 450 mm.

    python3 datasets/parts/make_nested_sheet.py > datasets/parts/nested_sheet.ngc

Every part is described by closed contours in its own frame (vertices with DXF-style bulges,
bulge = tan(sweep / 4), counter-clockwise), placed on the sheet, and cut the way a plasma
CAM program cuts it: the holes of a part first (counter-clockwise, pierced inside the hole,
a straight lead-in to the edge), then its outline (clockwise, pierced outside, a straight
lead-in at right angles to the edge). Each cut is M3, a pierce dwell (G4), the lead-in and
the loop at F4800 (80 mm/s), then M5. Rapids are straight G0 moves; `machplan run` re-plans
them round the parts already cut. No Z words: the gantry's torch height axis is driven by the
executor, not by the program. The output depends only on this script (no randomness).
"""
import math
import sys

FEED = 4800          # mm/min = 80 mm/s
PIERCE_S = 0.5       # pierce dwell, s
LEAD_OUT = 6.0       # outline lead-in length, mm (pierce this far outside the part)
SHEET_AT = (100.0, 100.0)  # sheet corner in machine coordinates, mm


def fmt(v):
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def rounded_rect(w, h, r):
    """Counter-clockwise w x h rectangle with corner radius r, starting mid right edge."""
    b = math.tan(math.pi / 8)  # quarter circle
    return [((w, h / 2), 0), ((w, h - r), b), ((w - r, h), 0), ((r, h), b), ((0, h - r), 0),
            ((0, r), b), ((r, 0), 0), ((w - r, 0), b), ((w, r), 0)]


def circle(cx, cy, r):
    """Counter-clockwise circle as two half arcs, starting at its bottom point."""
    return [((cx, cy - r), 1.0), ((cx, cy + r), 1.0)]


def disc(cx, cy, r):
    """Counter-clockwise circle as two half arcs, starting at its rightmost point."""
    return [((cx + r, cy), 1.0), ((cx - r, cy), 1.0)]


def slot(cx, cy, length, width):
    """Counter-clockwise obround slot along X, starting mid bottom edge."""
    r, half = width / 2, length / 2 - width / 2
    return [((cx, cy - r), 0), ((cx + half, cy - r), 1.0), ((cx + half, cy + r), 0),
            ((cx - half, cy + r), 1.0), ((cx - half, cy - r), 0)]


def bracket():
    """L-shaped bracket 160 x 120 with a R10 fillet in its inner corner, start mid right edge."""
    b = math.tan(math.pi / 8)
    return [((160, 20), 0), ((160, 40), 0), ((50, 40), -b), ((40, 50), 0), ((40, 120), 0),
            ((0, 120), 0), ((0, 0), 0), ((160, 0), 0)]


def gusset():
    """Right triangle, legs 110, corners rounded R6 (a fillet at each corner), start mid hypotenuse."""
    r = 6.0
    t135 = math.tan(math.radians(135) / 4)  # the path turns 135 degrees at the acute corners
    t90 = math.tan(math.pi / 8)
    s = r * math.tan(math.radians(135) / 2)  # fillet tangent length at those corners
    q = s / math.sqrt(2)
    return [((55, 55), 0), ((q, 110 - q), t135), ((0, 110 - s), 0), ((0, r), t90), ((r, 0), 0),
            ((110 - s, 0), t135), ((110 - q, q), 0)]


def reversed_contour(c):
    """The same contour walked the other way (bulges negated and moved with their spans)."""
    n = len(c)
    return [(c[(n - k) % n][0], -c[(2 * n - k - 1) % n][1]) for k in range(n)]


def arc_center(a, b, bulge):
    cx, cy = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
    dx, dy = b[0] - a[0], b[1] - a[1]
    k = 0.25 * (1 / bulge - bulge)  # offset of the centre along the left normal, per chord length
    return cx - dy * k, cy + dx * k


class Writer:
    def __init__(self):
        self.lines = []
        self.cuts = 0

    def out(self, s=""):
        self.lines.append(s)

    def cut(self, pierce, contour, label):
        """Pierce at `pierce`, straight lead-in to vertex 0, the loop, torch off."""
        self.cuts += 1
        self.out(f"({label})")
        self.out(f"G0 X{fmt(pierce[0])} Y{fmt(pierce[1])}")
        self.out("M3 S1")
        self.out(f"G4 P{PIERCE_S}")
        p0 = contour[0][0]
        self.out(f"G1 X{fmt(p0[0])} Y{fmt(p0[1])} F{FEED}")
        n = len(contour)
        for i in range(n):
            a, bulge = contour[i]
            b = contour[(i + 1) % n][0]
            if bulge == 0:
                self.out(f"G1 X{fmt(b[0])} Y{fmt(b[1])}")
            else:
                cx, cy = arc_center(a, b, bulge)
                g = "G3" if bulge > 0 else "G2"
                self.out(f"{g} X{fmt(b[0])} Y{fmt(b[1])} I{fmt(cx - a[0])} J{fmt(cy - a[1])}")
        self.out("M5")


def place(contour, ox, oy):
    return [((p[0] + ox, p[1] + oy), b) for p, b in contour]


def hole(w, cx, cy, r, ox, oy, label):
    """A round hole: pierced on the centre line, lead-in down to the bottom of the circle."""
    lead = min(0.6 * r, 8.0)
    w.cut((ox + cx, oy + cy - r + lead), place(circle(cx, cy, r), ox, oy), label)


def outline(w, contour, normal, ox, oy, label):
    """Clockwise outline from vertex 0, pierced LEAD_OUT away along the outward `normal`."""
    cw = reversed_contour(contour)
    # Rotate so the walk still starts at the original vertex 0.
    k = next(i for i, (p, _) in enumerate(cw) if p == contour[0][0])
    cw = cw[k:] + cw[:k]
    p0 = cw[0][0]
    w.cut((ox + p0[0] + LEAD_OUT * normal[0], oy + p0[1] + LEAD_OUT * normal[1]), place(cw, ox, oy), label)


def main():
    w = Writer()
    sx, sy = SHEET_AT
    w.out("(nested_sheet.ngc - plasma sheet 1030 x 450 mm: 4 flanges, 3 brackets, 4 discs, 3 gussets)")
    w.out("(Generated by datasets/parts/make_nested_sheet.py; do not edit by hand. Units mm,)")
    w.out(f"(machine coordinates, sheet corner at X{fmt(sx)} Y{fmt(sy)}. F{FEED} = 80 mm/s, pierce dwell {PIERCE_S} s.)")
    w.out("(Per part: holes first, counter-clockwise, then the outline, clockwise.)")
    w.out("G21 G90 G17 G40 G94 G91.1")

    # Parts are cut left to right, each outline pierced on its right-hand side (towards the
    # next part), so that the rapids need not cross the parts already cut.
    right = (1.0, 0.0)
    # Row 1: four flange plates 200 x 120, R10 corners, four 14 mm bolt holes and a 40 mm bore.
    for i in range(4):
        ox, oy = sx + 20 + i * 230, sy + 20
        name = f"flange {i + 1}"
        for j, (hx, hy) in enumerate([(20, 20), (20, 100), (180, 100), (180, 20)]):
            hole(w, hx, hy, 7, ox, oy, f"{name}: bolt hole {j + 1}, 14 mm")
        hole(w, 100, 60, 20, ox, oy, f"{name}: bore, 40 mm")
        outline(w, rounded_rect(200, 120, 10), right, ox, oy, f"{name}: outline")

    # Row 2: three L brackets 160 x 120 with three 12 mm holes and a 30 x 12 slot.
    for i in range(3):
        ox, oy = sx + 20 + i * 190, sy + 170
        name = f"bracket {i + 1}"
        for j, (hx, hy) in enumerate([(20, 100), (20, 20)]):
            hole(w, hx, hy, 6, ox, oy, f"{name}: hole {j + 1}, 12 mm")
        w.cut((ox + 100, oy + 20), place(slot(100, 20, 30, 12), ox, oy), f"{name}: slot 30 x 12")
        hole(w, 140, 20, 6, ox, oy, f"{name}: hole 3, 12 mm")
        outline(w, bracket(), right, ox, oy, f"{name}: outline")

    # Row 2, right: four discs of 80 mm with a 25 mm bore and three 8 mm holes on a 55 mm circle.
    for i in range(4):
        ox, oy = sx + 600 + i * 110, sy + 170
        name = f"disc {i + 1}"
        for j in range(3):
            a = math.radians(150 + 120 * j)
            hole(w, 40 + 27.5 * math.cos(a), 40 + 27.5 * math.sin(a), 4, ox, oy, f"{name}: hole {j + 1}, 8 mm")
        hole(w, 40, 40, 12.5, ox, oy, f"{name}: bore, 25 mm")
        outline(w, disc(40, 40, 40), right, ox, oy, f"{name}: outline")

    # Row 3: three gussets (right triangles, legs 110, R6 corners), one 16 mm hole each, pierced
    # outside the hypotenuse.
    diagonal = (math.sqrt(0.5), math.sqrt(0.5))
    for i in range(3):
        ox, oy = sx + 20 + i * 135, sy + 320
        name = f"gusset {i + 1}"
        hole(w, 30, 30, 8, ox, oy, f"{name}: hole, 16 mm")
        outline(w, gusset(), diagonal, ox, oy, f"{name}: outline")

    w.out("G0 X0 Y0")
    w.out("M2")
    w.lines.insert(4, f"({w.cuts} cuts)")
    sys.stdout.write("\n".join(w.lines) + "\n")


if __name__ == "__main__":
    main()
