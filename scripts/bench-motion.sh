#!/usr/bin/env bash
# Motion blur against no blur at equal spp, side by side: for each run,
# the same frames rendered without blur (A) and with `--motion-blur` and the
# given blur flags (B), interleaved A, B, A, B, ... so the machine's load
# falls on both alike. Reads every frame log and prints per-stage medians
# (evaluate, build, trace, total; SAH cost; motion steps) and B/A ratios of
# the medians, as a Markdown table row per stage.
#
#   scripts/bench-motion.sh BINARY SCENE FRAMES [RUNS] -- [render flags...] [-- blur flags...]
#   scripts/bench-motion.sh target/release/soupray animations/walker/walker.glb 0-48:4 3 -- --spp 16 -- --shutter 0.5
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,11p' "$0" >&2; exit 2; }
bin=$1 scene=$2 frames=$3 runs=3
shift 3
if [ $# -gt 0 ] && [ "$1" != "--" ]; then runs=$1; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
common=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do common+=("$1"); shift; done
[ $# -gt 0 ] && shift
blur=("$@")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for i in $(seq "$runs"); do
  "$bin" render "$scene" --frames "$frames" --out "$tmp/A$i" --quiet --name 'r.####.exr' "${common[@]}"
  "$bin" render "$scene" --frames "$frames" --out "$tmp/B$i" --quiet --name 'r.####.exr' "${common[@]}" --motion-blur "${blur[@]}"
done
python3 - "$tmp" <<'PY'
import glob, json, statistics, sys
tmp = sys.argv[1]
rows = {"A": [], "B": []}
pairs = {}
for v in "AB":
    for f in sorted(glob.glob(f"{tmp}/{v}*/r.*.json")):
        d = json.load(open(f))
        run = f.split("/")[-2][1:]
        pairs.setdefault((run, d["frame"]), {})[v] = d["timings_ms"]["total"]
        t = d["timings_ms"]
        m = d.get("motion") or {}
        rows[v].append({
            "evaluate": t["evaluate"], "build": t["build"], "trace": t["trace"],
            "total": t["total"], "sah": d["build"]["sah_cost"],
            "steps": m.get("steps", 1), "rays": d["render"]["rays"],
            "extra_evaluate": m.get("extra_evaluate_ms", 0.0),
            "extra_build": m.get("extra_build_ms", 0.0),
        })
n = len(rows["A"])
print(f"{n} frame renders per variant")
med = lambda v, k: statistics.median(r[k] for r in rows[v])
print("| stage | no blur (median) | blur (median) | blur / no blur |")
print("|---|---:|---:|---:|")
for k, name, fmt in [("evaluate", "evaluate ms", "%.2f"), ("build", "build ms", "%.2f"),
                     ("trace", "trace ms", "%.1f"), ("total", "total ms", "%.1f"),
                     ("sah", "SAH cost", "%.2f"), ("rays", "rays", "%.0f")]:
    a, b = med("A", k), med("B", k)
    print(f"| {name} | {fmt % a} | {fmt % b} | {b / a:.2f}x |")
ratios = [p["B"] / p["A"] for p in pairs.values() if "A" in p and "B" in p]
print("median of per-frame total ratios (same frame, same run): %.2fx" % statistics.median(ratios))
steps = [r["steps"] for r in rows["B"]]
print("blur: motion steps min %d / median %d / max %d; extra evaluate median %.2f ms, extra build (bounds) median %.2f ms"
      % (min(steps), statistics.median(steps), max(steps), med("B", "extra_evaluate"), med("B", "extra_build")))
PY
