#!/usr/bin/env bash
# The hybrid guard beside Franco Garcia and Horikawa's Tables 2 and 3 ("Manual and servo
# assisted, hybrid system for position control in machine tools"): runs `machplan guard --json`
# over the paper's configurations with the paper strategy, the latency sweep that chose the
# default link latency, and the predictive strategy at T = 0.5 mm, and writes a markdown report.
#
#   bench/guard_paper.sh [MACHPLAN_BINARY] > bench/results/guard_paper.md
#
# MACHPLAN_BINARY defaults to build/release/cli/machplan, then build/test/cli/machplan. Every
# run is seeded; the same binary gives the same tables. STROKES (default 100) sets the random
# strokes per paper configuration, BEYOND (default 200) per predictive configuration.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-}
if [[ -z "$bin" ]]; then
  for b in build/release/cli/machplan build/test/cli/machplan; do [[ -x "$b" ]] && bin=$b && break; done
fi
[[ -x "$bin" ]] || { echo "no machplan binary (give its path)" >&2; exit 2; }
strokes=${STROKES:-100}
beyond=${BEYOND:-200}
export ASAN_OPTIONS=detect_leaks=0
prof=datasets/profiles

run() {  # profile side feed T strategy offset strokes [latency_ms]
  local lat=()
  [[ -n "${8:-}" ]] && lat=(--latency-ms "$8")
  "$bin" guard "$prof/$1.dxf" --side "$2" --tool-radius 5 --tolerance "$4" --feed "$3" --strategy "$5" \
    --offset "$6" --operator "random:$7" --seed 1 --json "${lat[@]}"
}

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Paper strategy, the paper's configurations.
for feed in 12 18; do
  for T in 1 2 3 4 5; do run paper_triangle outside $feed $T paper paper "$strokes" > "$tmp/t2a_${feed}_${T}.json"; done
  for T in 4 4.5 5; do run paper_quadrilateral inside $feed $T paper paper "$strokes" > "$tmp/t2b_${feed}_${T}.json"; done
done
run paper_heptagon outside 12 4.5 paper paper "$strokes" > "$tmp/t3_outside.json"
run paper_heptagon inside 12 4.5 paper paper "$strokes" > "$tmp/t3_inside.json"
# The latency sweep behind the default (triangle, 12 and 18 mm/s, T = 1 .. 5).
for L in 90 120 150 180 210; do
  for feed in 12 18; do
    for T in 1 2 3 4 5; do run paper_triangle outside $feed $T paper paper 40 $L > "$tmp/sweep_${L}_${feed}_${T}.json"; done
  done
done
# Beyond: predictive, T = 0.5 mm, the same latency.
for feed in 12 18 100; do
  run paper_triangle outside $feed 0.5 predictive robust "$beyond" > "$tmp/b_${feed}_triangle_outside.json"
  run paper_quadrilateral inside $feed 0.5 predictive robust "$beyond" > "$tmp/b_${feed}_quadrilateral_inside.json"
  run paper_heptagon outside $feed 0.5 predictive robust "$beyond" > "$tmp/b_${feed}_heptagon_outside.json"
  run paper_heptagon inside $feed 0.5 predictive robust "$beyond" > "$tmp/b_${feed}_heptagon_inside.json"
done

# Automatic finishing after three strokes: single pass, and the paper's double pass (0.3 mm over).
for prof in paper_triangle arc_profile; do
  for allow in 0 0.3; do
    extra=()
    [[ "$allow" != 0 ]] && extra=(--finish-allowance "$allow")
    "$bin" guard "datasets/profiles/$prof.dxf" --side outside --tool-radius 5 --tolerance 0.5 --operator random:3 --seed 3 --finish \
      "${extra[@]}" --json > "$tmp/f_${prof}_${allow}.json"
  done
done
"$bin" guard "datasets/profiles/paper_quadrilateral.dxf" --side inside --tool-radius 5 --tolerance 0.5 --operator random:3 --seed 3 --finish \
  --json > "$tmp/f_paper_quadrilateral_0.json"

python3 - "$tmp" "$bin" "$strokes" "$beyond" <<'EOF'
import json, os, sys, datetime, platform
tmp, binary, strokes, beyond = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
def load(name): return json.load(open(os.path.join(tmp, name + ".json")))
def und(r): return "-" if r["successes"] == 0 else "%.2f" % r["mean_undercut_mm"]
paper2a = {(12,1):(17,0,None),(12,2):(17,3,0.15),(12,3):(17,11,0.54),(12,4):(18,16,1.25),(12,5):(20,20,2.50),
           (18,1):(15,1,0.50),(18,2):(19,4,0.25),(18,3):(18,14,0.68),(18,4):(19,17,1.15),(18,5):(20,19,2.63)}
paper2b = {(12,4):(23,22,1.40),(18,4):(25,25,1.10),(12,4.5):(28,27,2.00),(18,4.5):(28,28,1.95),(12,5):(28,28,2.46),(18,5):(28,28,2.48)}
print("# Hybrid guard: the paper's Tables 2 and 3 beside ours")
print()
print("Made by `bench/guard_paper.sh %s` (STROKES=%s, BEYOND=%s) on %s, %s." % (binary, strokes, beyond, datetime.date.today(), platform.machine()))
print()
print("Paper: Franco Garcia and Horikawa, \"Manual and servo assisted, hybrid system for position control in machine")
print("tools\", Tables 2 and 3 (human operator, joystick, MATLAB on a PC, RS-232C to an NSK controller). Ours: the")
print("simulated XY table (datasets/machines/xy_table.yaml), the rebuilt profiles (datasets/profiles/paper_*.dxf,")
print("reconstructed: the paper gives no dimensions), tool radius 5 mm (reconstructed), the paper's offset method, the")
print("`paper` strategy (ask the position, compare d <= T, send a stop) with the default link round trip of 150 ms,")
print("and the seeded random operator (`--operator random:N`: strokes aimed at the part from random places). Success:")
print("the tool centre never entered the prohibited region; under-cut: the material left beyond the offset profile where")
print("the tool stopped, averaged over the successes as the paper does.")
print()
print("## Table 2 (a): external machining of the triangle")
print()
print("| V (mm/s) | T (mm) | paper attempts | paper successes | paper under-cut (mm) | paper % | our attempts | our successes | our under-cut (mm) | our % | our max invasion (mm) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for feed in (12, 18):
    for T in (1, 2, 3, 4, 5):
        a, s, u = paper2a[(feed, T)]
        r = load("t2a_%d_%d" % (feed, T))
        print("| %d | %.1f | %d | %d | %s | %.2f | %d | %d | %s | %.2f | %.2f |" % (feed, T, a, s, "-" if u is None else "%.2f" % u,
              100.0 * s / a, r["attempts"], r["successes"], und(r), r["success_percent"], r["max_invasion_mm"]))
print()
print("## Table 2 (b): internal machining of the quadrilateral (a pocket)")
print()
print("| V (mm/s) | T (mm) | paper attempts | paper successes | paper under-cut (mm) | paper % | our attempts | our successes | our under-cut (mm) | our % | our max invasion (mm) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for T in (4, 4.5, 5):
    for feed in (12, 18):
        a, s, u = paper2b[(feed, T)]
        r = load("t2b_%d_%s" % (feed, ("%g" % T)))
        print("| %d | %.1f | %d | %d | %.2f | %.2f | %d | %d | %s | %.2f | %.2f |" % (feed, T, a, s, u, 100.0 * s / a,
              r["attempts"], r["successes"], und(r), r["success_percent"], r["max_invasion_mm"]))
print()
print("## Table 3: the irregular seven-sided profile, 12 mm/s, T = 4.5 mm")
print()
print("| side | paper attempts | paper successes | paper under-cut (mm) | paper % | our attempts | our successes | our under-cut (mm) | our % |")
print("|---|---|---|---|---|---|---|---|---|")
for side, (a, s, u) in (("outside", (46, 44, 0.90)), ("inside", (46, 43, 1.20))):
    r = load("t3_" + side)
    print("| %s | %d | %d | %.2f | %.2f | %d | %d | %s | %.2f |" % (side, a, s, u, 100.0 * s / a, r["attempts"], r["successes"], und(r), r["success_percent"]))
print()
print("## Choosing the link latency")
print()
print("The paper gives no figure for its delay; it blames \"the time spent since the moment in which a command is sent")
print("... asking for the position, until the moment in which the stop command is sent\". Sweep of the round trip L")
print("with the paper strategy on the triangle (40 strokes per cell), against Table 2 (a): the score is the root mean")
print("square difference of the success percentages over the ten cells.")
print()
print("| L (ms) | 12 mm/s: success % at T = 1..5 | 18 mm/s: success % at T = 1..5 | rms difference to the paper (points) |")
print("|---|---|---|---|")
best = None
for L in (90, 120, 150, 180, 210):
    cells, diffs = {}, []
    for feed in (12, 18):
        for T in (1, 2, 3, 4, 5):
            r = load("sweep_%d_%d_%d" % (L, feed, T))
            cells[(feed, T)] = r["success_percent"]
            a, s, _ = paper2a[(feed, T)]
            diffs.append(r["success_percent"] - 100.0 * s / a)
    rms = (sum(d * d for d in diffs) / len(diffs)) ** 0.5
    best = (rms, L) if best is None or rms < best[0] else best
    print("| %d | %s | %s | %.1f |" % (L, " / ".join("%.0f" % cells[(12, T)] for T in (1, 2, 3, 4, 5)),
          " / ".join("%.0f" % cells[(18, T)] for T in (1, 2, 3, 4, 5)), rms))
print()
print("Closest: L = %d ms (the default, `executor::kPaperLatencyS`, is 150 ms)." % best[1])
print()
print("## Beyond the paper: the predictive strategy, T = 0.5 mm, the same 150 ms latency")
print()
print("| V (mm/s) | profile | side | attempts | successes | invasions | max invasion (mm) | mean under-cut (mm) | max under-cut (mm) |")
print("|---|---|---|---|---|---|---|---|---|")
for feed in (12, 18, 100):
    for prof, side in (("triangle", "outside"), ("quadrilateral", "inside"), ("heptagon", "outside"), ("heptagon", "inside")):
        r = load("b_%d_%s_%s" % (feed, prof, side))
        print("| %d | %s | %s | %d | %d | %d | %.4f | %.4f | %.4f |" % (feed, prof, side, r["attempts"], r["successes"], r["invasions"],
              r["max_invasion_mm"], r["mean_undercut_mm"], r["max_undercut_mm"]))
print()
print("The paper's own figures: an average under-cut of about 0.5 mm and more, success below 100 % under 4 mm.")
print()
print("## Automatic finishing (predictive roughing, 3 strokes, then `--finish`)")
print()
print("Deviation: the largest distance of the simulated true tool centre from the pass's path (the offset profile for")
print("the final pass, the profile offset 0.3 mm further out for the first of two passes). The issue asks <= 0.05 mm.")
print()
print("| profile | side | passes | pass | completed | max deviation (mm) | rms (mm) | time (s) |")
print("|---|---|---|---|---|---|---|---|")
for prof, side, allow in (("paper_triangle", "outside", "0"), ("paper_triangle", "outside", "0.3"), ("arc_profile", "outside", "0"),
                          ("arc_profile", "outside", "0.3"), ("paper_quadrilateral", "inside", "0")):
    r = load("f_%s_%s" % (prof, allow))
    for f in r["finish"]:
        print("| %s | %s | %d | %s | %s | %.4f | %.4f | %.1f |" % (prof, side, len(r["finish"]),
              "+%g mm" % f["allowance_mm"] if f["allowance_mm"] > 0 else "final", f["completed"], f["max_deviation_mm"],
              f["rms_deviation_mm"], f["time_s"]))
print()
print("## Reading")
print()
print("- The trend of Tables 2 and 3 is reproduced: with the paper's check-and-stop over a 150 ms round trip the")
print("  success rate rises with T to 98-100 % at 5 mm, and the under-cut of the successes grows with T.")
print("- Where ours differs: one fixed latency makes the overshoot proportional to the feed, so at 18 mm/s our success")
print("  lags the paper's at T = 3-4 mm, and at 12 mm/s it leads it at T = 2-3 mm. The paper's two feeds give nearly")
print("  the same rates, which no fixed delay does: its delay was probably not one fixed time (MATLAB and a serial")
print("  poll; its operators may also have slowed near the part). The sweep shows the compromise.")
print("- Table 3's under-cut (0.9 and 1.2 mm at T = 4.5 mm) is below ours (about 2.2 mm) and below its own Table 2 at")
print("  T = 4-5 mm; with a random operator pushing at the profile our under-cut is T minus the overshoot, whatever")
print("  the shape.")
print("- The predictive strategy, under the same 150 ms link, has no invasion in 2400 strokes up to 100 mm/s (8 x the")
print("  paper's feed) at T = 0.5 mm, with a mean under-cut of 0.05-0.06 mm (its 0.08 mm standoff less the table's")
print("  overshoot when it brakes): 10 to 50 times below the paper's.")
EOF
