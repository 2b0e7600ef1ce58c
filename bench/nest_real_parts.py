#!/usr/bin/env python3
"""A shop's job from real drawings: nest them on whole sheets, then run every sheet's program.

    bench/nest_real_parts.py --machplan build/release/cli/machplan --drawings DIR [--sets N]
                             [--time S] [--sheet 2500x1250] [--out DIR]

Every DXF drawing in DIR that is one part (machplan nest refuses the others, and they are
listed as left out) goes in the job, as many copies as its name says ("..._x4.dxf",
"..._8pcs...": 4, 8; else 1) times --sets. The job (a YAML file written beside the results)
nests them on sheets of --sheet with a 10 mm margin and 6 mm between parts, every rotation
allowed, part-in-part on, in --time seconds; each sheet's program (arc lead-ins, kerf 1.5 mm
compensated, QtPlasmaC's hole rules, 3000 mm/min) is then run on the simulated gantry with
`machplan run`.
Prints the nest's figures, how many parts lie in another part's hole, and each sheet's run.
"""
import argparse
import json
import os
import re
import subprocess
import sys


def quantity(name):
    m = re.search(r"_x(\d+)", name) or re.search(r"_(\d+)pcs", name)
    return int(m.group(1)) if m else 1


def one_part(machplan, path):
    r = subprocess.run([machplan, "nest", path, "--sheet", "5000x5000", "--time", "0", "--json"], capture_output=True, text=True)
    return r.returncode == 0, r.stderr.strip().splitlines()[-1] if r.returncode != 0 and r.stderr.strip() else ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--machplan", required=True)
    ap.add_argument("--drawings", required=True)
    ap.add_argument("--sets", type=int, default=1)
    ap.add_argument("--time", default="60")
    ap.add_argument("--sheet", default="2500x1250")
    ap.add_argument("--machine", default="thermal_gantry")
    ap.add_argument("--out", default="real_parts_out")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    width, height = a.sheet.split("x")
    parts, left_out = [], []
    for name in sorted(os.listdir(a.drawings)):
        if not name.lower().endswith(".dxf"):
            continue
        path = os.path.abspath(os.path.join(a.drawings, name))
        ok, why = one_part(a.machplan, path)
        if ok:
            parts.append((path, quantity(name) * a.sets))
        else:
            left_out.append((name, why))
    job = os.path.join(a.out, "job.yaml")
    with open(job, "w") as f:
        f.write(f"sheets:\n  - {{width_mm: {width}, height_mm: {height}, count: 20, margin_mm: 10}}\nspacing_mm: 6\nparts:\n")
        for path, q in parts:
            f.write(f"  - {{file: '{path}', quantity: {q}, rotations: any}}\n")
    print(f"{len(parts)} kinds of part, {sum(q for _, q in parts)} copies; left out: {len(left_out)}")
    for name, why in left_out:
        print(f"  left out {name}: {why[:150]}")
    cmd = [a.machplan, "nest", job, "--time", a.time, "--out", a.out, "--machine", a.machine, "--feed", "3000", "--kerf", "1.5",
           "--holes", "2", "--json"]
    print("$", " ".join(cmd))
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode not in (0, 3):
        sys.exit(f"machplan nest failed ({r.returncode}): {r.stderr}")
    j = json.loads(r.stdout)
    print(f"certified {j['certified']}, {len(j['placements'])} placed, {len(j['unplaced'])} not placed, "
          f"{len(j['sheets'])} sheet(s), search {j['search_s']:.1f} s of nominal work")
    for s in j["sheets"]:
        print(f"  sheet {s['sheet']}: {s['parts']} parts, used length {s['used_length_mm']:.1f} mm, utilisation "
              f"{100 * s['utilisation']:.1f} %, {s['pierces']} pierces, cut {s['cut_length_mm'] / 1000:.1f} m, "
              f"cycle {s['cycle_s']:.0f} s planned, leads shortened {s['leads_shortened']}, cramped {s['leads_cramped']}")
        run = subprocess.run([a.machplan, "run", s["program"], "--machine", a.machine, "--json"], capture_output=True, text=True)
        rj = json.loads(run.stdout) if run.stdout.startswith("{") else {}
        print(f"    run: exit {run.returncode}, status {rj.get('status')}, {len(rj.get('cuts', []))} cuts, "
              f"cycle {rj.get('cycle_time_s', 0):.0f} s, contour error max {rj.get('max_contour_error_mm', float('nan')):.3f} mm")
    # Parts in other parts' holes are seen in the pictures (DIR/sheet_K.png).


if __name__ == "__main__":
    main()
