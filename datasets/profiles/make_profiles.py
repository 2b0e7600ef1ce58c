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


# Profiles of the hybrid manual / servo-assisted guard. Franco Garcia and Horikawa ("Manual and
# servo assisted, hybrid system for position control in machine tools") test a triangle
# (external machining), a quadrilateral (internal) and an irregular seven-sided profile (both
# sides) but give no dimensions: the shapes below are RECONSTRUCTED to fit their 400 x 350 mm
# table with room for a tool around them (see README.md). Drawn as LINE entities, the only
# kind their pre-processor reads, in order and counter-clockwise.
def polygon_lines(d, pts, layer="CUT"):
    for i in range(len(pts)):
        d.line(pts[i], pts[(i + 1) % len(pts)], layer)


PAPER_TRIANGLE = [(0, 0), (120, 0), (45, 95)]
PAPER_QUADRILATERAL = [(0, 0), (130, 10), (120, 100), (-10, 80)]
PAPER_HEPTAGON = [(0, 0), (90, -10), (140, 30), (120, 80), (70, 60), (30, 100), (-20, 50)]


def paper_profiles():
    for name, pts in [("paper_triangle.dxf", PAPER_TRIANGLE), ("paper_quadrilateral.dxf", PAPER_QUADRILATERAL),
                      ("paper_heptagon.dxf", PAPER_HEPTAGON)]:
        d = Dxf()
        polygon_lines(d, pts)
        d.write(name)


def arc_profile():
    # A cam-like plate of lines and arcs, both ways round: a convex R40 end, one concave R3
    # fillet (smaller than a 5 mm tool: their offset collapses when the part is machined
    # from outside), a concave R20 scallop in the top edge, a rounded R8 corner, and a 20 mm
    # hole drawn as a CIRCLE. Outline counter-clockwise from (0, 0).
    d = Dxf()
    d.line((3, 0), (100, 0))
    d.arc((100, 40), 40, -90, 90)            # convex end: (100, 0) -> (100, 80), ccw
    d.line((100, 80), (73, 80))
    d.arc((73, 83), 3, 180, 270)             # concave fillet (73, 80) -> (70, 83) (drawn ccw, traversed cw)
    d.line((70, 83), (70, 100))
    d.line((70, 100), (60, 100))
    d.arc((40, 100), 20, 180, 360)           # concave scallop (60, 100) -> (20, 100), under the edge
    d.line((20, 100), (8, 100))
    d.arc((8, 92), 8, 90, 180)               # convex rounded corner (8, 100) -> (0, 92)
    d.line((0, 92), (0, 3))
    d.arc((3, 3), 3, 180, 270)               # convex small corner (0, 3) -> (3, 0)
    d.circle((100, 40), 10)
    d.write("arc_profile.dxf")


def narrow_slot():
    # Two separate contours, LWPOLYLINEs, counter-clockwise:
    # a 120 x 80 plate with an open slot 8 mm wide and 40 mm deep cut down from the middle of
    # its top edge: machined from outside, a tool of radius 4 or more cannot enter the slot;
    # a keyhole, a 40 x 40 square with a channel 6 mm wide and 30 mm long on its right side:
    # machined as a pocket, a tool of radius 3 or more cannot enter the channel.
    d = Dxf()
    d.lwpolyline([(0, 0), (120, 0), (120, 80), (64, 80), (64, 40), (56, 40), (56, 80), (0, 80)])
    d.lwpolyline([(150, 20), (190, 20), (190, 37), (220, 37), (220, 43), (190, 43), (190, 60), (150, 60)])
    d.write("narrow_slot.dxf")


if __name__ == "__main__":
    flange()
    bracket()
    nested_sheet()
    curved_plate()
    paper_profiles()
    arc_profile()
    narrow_slot()
