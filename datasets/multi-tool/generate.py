#!/usr/bin/env python3
"""Writes job.apt: a four-tool job on the trunnion-5axis block (../trunnion-5axis/part.stl), as a
CAM system that changes tools exports it (CUTTER before LOAD/TOOL, holder names in INSERT, the
flute and extension lengths in CAMWorks' CSI_SET_* statements, SELECT for the next tool).

The part: a 110 x 70 x 30 mm block with a dome (a cap of a 30 mm sphere) 30 mm off its centre
along x; the CAM zero on the top face at the stock's corner (x 0 .. 110, y 0 .. 70, z -30 .. 12.8).

  T1  16 mm flat end mill, 3-axis: faces the top around the dome in seven rows.
  T2  6 mm ball end mill, 5-axis: finishes the dome along its normals, rings 3 deg apart.
  T3  6 mm spot drill: spots the four corner holes 2 mm deep.
  T4  8.5 mm jobber drill, long: drills the four holes through (33 mm, tip 3 mm below the
      bottom), peck cycle.

Standard library only; the output is deterministic. Run from this folder.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
import cam_files  # noqa: E402  (datasets/cam_files.py: the dome block, shared with trunnion-5axis)

B = cam_files.DomeBlock
L, W, H, R, CX, CY, BASE, CZ, RB, CAM = B.L, B.W, B.H, B.R, B.CX, B.CY, B.BASE, B.CZ, B.RB, B.CAM
SAFE = H + 25                        # clearance plane, part frame
HOLES = [(-45.0, -25.0), (-45.0, 25.0), (45.0, -25.0), (45.0, 25.0)]


def cam(x, y, z):
    return (x + CAM[0], y + CAM[1], z + CAM[2])


def goto(p, n=None):
    if n is None:
        return "GOTO/%.4f,%.4f,%.4f" % p
    return "GOTO/%.4f,%.4f,%.4f,%.6f,%.6f,%.6f" % (p + n)


def tool(lines, number, cutter, holder, flutes, extension, rpm, next_tool):
    lines += ["INSERT/[HOLDER=%s]" % holder, "CUTTER/" + cutter, "LOAD/TOOL,%d" % number,
              "CSI_SET_FLUTE_LENGTH/%.1f" % flutes, "CSI_SET_EXTENSION_LENGTH/%.1f" % extension]
    if next_tool:
        lines.append("SELECT/TOOL,%d" % next_tool)
    lines += ["COOLNT/FLOOD", "SPINDL/%d,RPM,CLW" % rpm]


def facing(lines):
    r = 8.0
    keep_out = RB + r + 1.0
    lines.append("MULTAX/OFF")
    rows = 7                         # from 2 mm inside each long edge, step-over under 10 mm
    for row in range(rows):
        y = -W / 2 + r - 2.0 + row * (W - 2 * r + 4.0) / (rows - 1)
        xs = [-L / 2 - r - 2.0 + 5.0 * k for k in range(int((L + 2 * r + 4.0) / 5.0) + 1)]
        if row % 2:
            xs.reverse()
        for seg in cam_files.outside_circle(xs, y, CX, CY, keep_out):
            lines += ["RAPID", goto(cam(seg[0], y, SAFE)), "RAPID", goto(cam(seg[0], y, H + 2.0)),
                      "FEDRAT/MMPM,400", goto(cam(seg[0], y, H)), "FEDRAT/MMPM,1600"]
            lines += [goto(cam(x2, y, H)) for x2 in seg[1:]]
            lines += ["RAPID", goto(cam(seg[-1], y, SAFE))]


def dome(lines):
    lines += ["MULTAX/ON", "FEDRAT/MMPM,900"]
    first = True
    for p, n in cam_files.dome_rings(B, math.radians(3.0), 120):
        if first:
            lines += ["RAPID", goto(cam(p[0] + 25 * n[0], p[1] + 25 * n[1], p[2] + 25 * n[2]), n)]
            first = False
        lines.append(goto(cam(*p), n))
    apex = (CX, CY, CZ + R)
    lines += [goto(cam(*apex), (0.0, 0.0, 1.0)), "RAPID", goto(cam(apex[0], apex[1], SAFE), (0.0, 0.0, 1.0))]


def drilling(lines, cycle):
    lines += ["MULTAX/OFF", "RAPID", goto(cam(HOLES[0][0], HOLES[0][1], SAFE)), "CYCLE/INIT", cycle]
    lines += [goto(cam(x, y, H)) for x, y in HOLES]
    lines.append("CYCLE/OFF")


def main():
    lines = ["PARTNO/MULTI-TOOL DOME BLOCK (machplan generate.py)", "UNIT/MM"]
    tool(lines, 1, "16.,0,8.,0,0,0,75.", "BT40-SLN16", 26.0, 45.0, 3000, 2)
    facing(lines)
    tool(lines, 2, "6.,3.,0,3.,0,0,57.", "BT40-SF6 SHRINK", 15.0, 60.0, 9000, 3)
    dome(lines)
    tool(lines, 3, "6.,0,3.,1.802582,31.,0,50.", "BT40-ER16", 8.0, 25.0, 3200, 4)
    drilling(lines, "CYCLE/DRILL,FEDTO,2.,MMPM,200.,RAPTO,3.,RTRCTO,25.")
    tool(lines, 4, "8.5,0,4.25,2.55,31.,0,117.", "BT40-ER16", 75.0, 80.0, 2200, 0)
    drilling(lines, "CYCLE/DEEP2,FEDTO,33.,1STPECK,6.,SUBPECK,4.,MMPM,250.,RAPTO,3.,RTRCTO,25.")
    lines += ["COOLNT/OFF", "FINI"]
    with open("job.apt", "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
