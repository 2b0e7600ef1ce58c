#!/usr/bin/env python3
"""machplan nest on the ESICUP strip-packing instances, for comparison with other nesters.

    bench/nest_esicup.py --machplan build/release/cli/machplan --instances DIR [--time S] [--seed N] [NAME...]

DIR holds the instances in the jagua-rs / sparrow JSON format (`data/input/<name>.json` of
github:JeroenGar/sparrow) and, optionally, `records.tsv` (instance, strip_width, best_length,
density, ...) with the best-known densities. Each instance's items become DXF drawings (one
closed polyline each) in a temporary folder, nested with no spacing and no margin on one sheet
of the strip's height H and a length that holds them all; the used length L gives the density
part area / (H x L). Prints one tab-separated row per instance.

With --place DIR, each nest is also written to DIR/<name>.place, one line per part,
`item_id rotation_deg tx ty` (the item's polygon turned about its origin, then moved), the form an
independent checker of strip-packing layouts can read.
"""
import argparse
import json
import os
import subprocess
import tempfile
import time


def area(pts):
    return 0.5 * sum(pts[i][0] * pts[(i + 1) % len(pts)][1] - pts[(i + 1) % len(pts)][0] * pts[i][1] for i in range(len(pts)))


def drawing(pts):
    s = f"0\nLWPOLYLINE\n8\nCUT\n90\n{len(pts)}\n70\n1\n" + "".join(f"10\n{x!r}\n20\n{y!r}\n" for x, y in pts)
    return "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n" + s + "0\nENDSEC\n0\nEOF\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--machplan", required=True)
    ap.add_argument("--instances", required=True)
    ap.add_argument("--time", default="2", help="machplan nest --time (seconds of nominal work)")
    ap.add_argument("--seed", default="1", help="machplan nest --seed")
    ap.add_argument("--place", help="write each nest as DIR/<name>.place (item_id rotation_deg tx ty per line)")
    ap.add_argument("names", nargs="*")
    a = ap.parse_args()
    names = a.names or sorted(f[:-5] for f in os.listdir(a.instances) if f.endswith(".json"))
    records = {}
    rec = os.path.join(a.instances, "records.tsv")
    if os.path.exists(rec):
        for line in open(rec):
            f = line.rstrip("\n").split("\t")
            if len(f) > 3 and f[0] != "instance":
                records[f[0]] = f[3]
    print("instance\tparts\tH\tL\tdensity\trecord_density\tseconds\tcertified")
    for name in names:
        inst = json.load(open(os.path.join(a.instances, name + ".json")))
        h = inst["strip_height"]
        with tempfile.TemporaryDirectory() as d:
            args, total, parts, rotations = [], 0.0, 0, set()
            for it in inst["items"]:
                pts = it["shape"]["data"]
                if pts[0] == pts[-1]:
                    pts = pts[:-1]
                total += abs(area(pts)) * it["demand"]
                parts += it["demand"]
                rotations.update(it["allowed_orientations"])
                path = os.path.join(d, f"i_{it['id']}.dxf")
                open(path, "w").write(drawing(pts))
                args.append(f"{path}:{it['demand']}")
            length = 3 * total / h + 2 * h
            t0 = time.monotonic()
            r = subprocess.run([a.machplan, "nest", *args, "--sheet", f"{length}x{h}", "--spacing", "0", "--margin", "0",
                                "--rotations", ",".join(str(x) for x in sorted(rotations)), "--time", a.time, "--seed", a.seed, "--json"],
                               capture_output=True, text=True)
            seconds = time.monotonic() - t0
        if r.returncode != 0:
            print(f"{name}\tfailed (exit {r.returncode}): {r.stderr.strip()[:200]}")
            continue
        out = json.loads(r.stdout)
        used = out["sheets"][0]["used_length_mm"]
        if a.place:
            os.makedirs(a.place, exist_ok=True)
            with open(os.path.join(a.place, name + ".place"), "w") as f:
                for p in out["placements"]:
                    item = os.path.basename(p["file"])[len("i_"):-len(".dxf")]
                    f.write(f"{item} {p['rotation_deg']!r} {p['translate_mm'][0]!r} {p['translate_mm'][1]!r}\n")
        print(f"{name}\t{parts}\t{h}\t{used:.3f}\t{total / (h * used):.3f}\t{records.get(name, '-')}\t{seconds:.2f}\t{out['certified']}")


if __name__ == "__main__":
    main()
