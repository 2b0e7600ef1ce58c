#!/usr/bin/env python3
"""Writes the bundled DXF profiles of this folder. Run from anywhere: python3 make_profiles.py

Plain ASCII DXF (R12-style sections, handles on every entity, $INSUNITS = 4, mm), written
by hand-rolled code so that no CAD package is needed and every number is known."""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


class Dxf:
    def __init__(self):
        self.body = []
        self.blocks = []  # BLOCKS section lines
        self.handle = 0x100

    def block(self, name, fill):
        """A block with base point (0, 0) whose entities `fill(d)` draws into a scratch Dxf."""
        inner = Dxf()
        inner.handle = self.handle + 0x1000
        fill(inner)
        self.blocks += ["0", "BLOCK", "2", name, "70", "0", "10", "0", "20", "0", "30", "0"] + inner.body + ["0", "ENDBLK"]

    def _start(self, kind, layer):
        self.handle += 1
        self.body += ["0", kind, "5", "%X" % self.handle, "8", layer]

    def line(self, a, b, layer="CUT"):
        self._start("LINE", layer)
        self.body += ["10", fmt(a[0]), "20", fmt(a[1]), "30", "0", "11", fmt(b[0]), "21", fmt(b[1]), "31", "0"]

    def arc(self, c, r, a1, a2, layer="CUT"):  # degrees, counter-clockwise from a1 to a2
        self._start("ARC", layer)
        self.body += ["10", fmt(c[0]), "20", fmt(c[1]), "30", "0", "40", fmt(r), "50", fmt(a1), "51", fmt(a2)]

    def circle(self, c, r, layer="CUT"):
        self._start("CIRCLE", layer)
        self.body += ["10", fmt(c[0]), "20", fmt(c[1]), "30", "0", "40", fmt(r)]

    def lwpolyline(self, pts, bulges=None, closed=True, layer="CUT"):
        bulges = bulges or [0] * len(pts)
        self._start("LWPOLYLINE", layer)
        self.body += ["90", str(len(pts)), "70", "1" if closed else "0"]
        for (x, y), b in zip(pts, bulges):
            self.body += ["10", fmt(x), "20", fmt(y)]
            if b:
                self.body += ["42", fmt(b)]

    def spline(self, degree, knots, ctrl, layer="CUT"):  # non-rational, planar
        self._start("SPLINE", layer)
        self.body += ["210", "0", "220", "0", "230", "1", "70", "8", "71", str(degree), "72", str(len(knots)),
                      "73", str(len(ctrl)), "74", "0"]
        for k in knots:
            self.body += ["40", fmt(k)]
        for x, y in ctrl:
            self.body += ["10", fmt(x), "20", fmt(y), "30", "0"]

    def ellipse(self, c, major, ratio, t0=0.0, t1=2 * math.pi, layer="CUT"):
        self._start("ELLIPSE", layer)
        self.body += ["10", fmt(c[0]), "20", fmt(c[1]), "30", "0", "11", fmt(major[0]), "21", fmt(major[1]), "31", "0",
                      "210", "0", "220", "0", "230", "1", "40", fmt(ratio), "41", fmt(t0), "42", fmt(t1)]

    def insert(self, name, at, cols=1, rows=1, dc=0, dr=0, layer="CUT"):
        self._start("INSERT", layer)
        self.body += ["2", name, "10", fmt(at[0]), "20", fmt(at[1]), "30", "0", "41", "1", "42", "1", "50", "0",
                      "70", str(cols), "71", str(rows), "44", fmt(dc), "45", fmt(dr)]

    def text(self, at, s, layer="NOTES"):
        self._start("TEXT", layer)
        self.body += ["10", fmt(at[0]), "20", fmt(at[1]), "30", "0", "40", "5", "1", s]

    def write(self, name):
        blocks = ["0", "SECTION", "2", "BLOCKS"] + self.blocks + ["0", "ENDSEC"] if self.blocks else []
        out = (["0", "SECTION", "2", "HEADER", "9", "$INSUNITS", "70", "4", "0", "ENDSEC"] + blocks +
               ["0", "SECTION", "2", "ENTITIES"] + self.body + ["0", "ENDSEC", "0", "EOF"])
        with open(os.path.join(HERE, name), "w") as f:
            f.write("\n".join(out) + "\n")


def fmt(v):
    return ("%.6f" % v).rstrip("0").rstrip(".") if abs(v) > 1e-12 else "0"


def rounded_rect(d, x0, y0, w, h, r):
    """Closed LWPOLYLINE, counter-clockwise, corners of radius r as quarter arcs (bulge tan(22.5 deg))."""
    b = math.tan(math.pi / 8)
    pts = [(x0 + r, y0), (x0 + w - r, y0), (x0 + w, y0 + r), (x0 + w, y0 + h - r),
           (x0 + w - r, y0 + h), (x0 + r, y0 + h), (x0, y0 + h - r), (x0, y0 + r)]
    d.lwpolyline(pts, [0, b, 0, b, 0, b, 0, b])


def flange():
    # Square flange 200 x 200 with 20 mm corner radii, 60 mm bore, 8 bolt holes of 13 mm on
    # a 150 mm pitch circle.
    d = Dxf()
    rounded_rect(d, -100, -100, 200, 200, 20)
    d.circle((0, 0), 30)
    for k in range(8):
        a = 2 * math.pi * k / 8
        d.circle((75 * math.cos(a), 75 * math.sin(a)), 6.5)
    d.text((-95, -95), "FLANGE 200 S235 t10")
    d.write("flange_plate.dxf")


def bracket():
    # L-shaped bracket 120 x 80 (legs 30 and 50 wide) from LINE and ARC entities written in a
    # scrambled order, some drawn backwards: an inner fillet of r 10 at (50, 30), a rounded
    # top-left corner of r 10, a slot 32 x 12 (two lines, two half circles) and a 10 mm hole.
    d = Dxf()
    d.line((120, 30), (120, 0))            # right edge, drawn downwards
    d.arc((10, 70), 10, 90, 180)           # top-left corner (10,80) -> (0,70)
    d.line((50, 40), (50, 80))             # inner vertical edge
    d.line((0, 0), (120, 0))               # bottom
    d.arc((80, 15), 6, 90, 270)            # slot, left half
    d.line((0, 70), (0, 0))                # left edge, drawn downwards
    d.line((60, 30), (120, 30))            # inner horizontal edge, drawn backwards
    d.line((100, 21), (80, 21))            # slot top
    d.arc((60, 40), 10, 180, 270)          # inner fillet (50,40) -> (60,30)
    d.line((10, 80), (50, 80))             # top edge
    d.arc((100, 15), 6, 270, 90)           # slot, right half
    d.line((80, 9), (100, 9))              # slot bottom
    d.circle((25, 20), 5)
    d.write("bracket_slot.dxf")


def nested_sheet():
    # A 600 x 300 sheet outline holding three parts: a plate with four holes, a ring (outer
    # circle, inner circle) with a small disc nested inside its hole, and a rounded tab.
    d = Dxf()
    d.lwpolyline([(0, 0), (600, 0), (600, 300), (0, 300)], layer="SHEET")
    d.lwpolyline([(20, 20), (220, 20), (220, 140), (20, 140)])
    for x, y in [(40, 40), (200, 40), (200, 120), (40, 120)]:
        d.circle((x, y), 5)
    d.circle((360, 150), 100)
    d.circle((360, 150), 60)
    d.circle((360, 150), 30)
    rounded_rect(d, 480, 40, 100, 220, 25)
    d.write("nested_sheet.dxf")


def curved_plate():
    # A 160 x ~100 plate whose top edge is a cubic B-spline wave, with an elliptical window
    # and four bolt holes placed as a 2 x 2 array of one block.
    d = Dxf()
    d.block("BOLT", lambda b: b.circle((0, 0), 4))
    d.line((0, 100), (0, 0))
    d.line((0, 0), (160, 0))
    d.line((160, 0), (160, 100))
    d.spline(3, [0, 0, 0, 0, 0.5, 1, 1, 1, 1], [(160, 100), (120, 115), (80, 85), (40, 115), (0, 100)])
    d.ellipse((50, 50), (30, 0), 0.5)
    d.insert("BOLT", (110, 25), cols=2, rows=2, dc=30, dr=50)
    d.write("curved_plate.dxf")


if __name__ == "__main__":
    flange()
    bracket()
    nested_sheet()
    curved_plate()
