#!/usr/bin/env bash
# Side-by-side trace time of two soupray binaries on one scene: interleaved
# runs (A, B, A, B, ...), each run's `timings_ms.trace` from its frame log,
# then the runs, the median and the rays traced per binary, and the median
# of the per-round ratios.
#
#   scripts/ab-trace.sh OLD_BINARY NEW_BINARY SCENE [RUNS] -- [render flags...]
#   scripts/ab-trace.sh /tmp/old/soupray target/release/soupray scene.gltf 5 -- --spp 64 --clay
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,7p' "$0" >&2; exit 2; }
a=$1 b=$2 scene=$3 runs=5
shift 3
if [ $# -gt 0 ] && [ "$1" != "--" ]; then runs=$1; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for i in $(seq "$runs"); do
  for v in A B; do
    bin=$a; [ "$v" = B ] && bin=$b
    rm -rf "$tmp/$v"
    "$bin" render "$scene" --frame 0 --out "$tmp/$v" --quiet --name 'r.####.exr' "$@"
    python3 -c 'import json,glob,sys; d=json.load(open(glob.glob(sys.argv[1]+"/r.*.json")[0])); print(sys.argv[2], d["timings_ms"]["trace"], d["render"]["rays"])' "$tmp/$v" "$v"
  done
done | python3 -c '
import sys, statistics
runs, rays = {}, {}
for line in sys.stdin:
    v, ms, n = line.split()
    runs.setdefault(v, []).append(float(ms))
    rays[v] = n
for v in "AB":
    t = sorted(runs[v])
    listed = ", ".join("%.0f" % x for x in t)
    print("%s: runs %s ms, median %.0f ms, rays %s" % (v, listed, statistics.median(t), rays[v]))
print("B/A median: %.3f" % (statistics.median(runs["B"]) / statistics.median(runs["A"])))
# Each B run follows its A run: their ratio leaves out the drift of the machine
# between rounds, which the medians above keep.
paired = sorted(b / a for a, b in zip(runs["A"], runs["B"]))
print("B/A per round: median %.3f (%.3f to %.3f)" % (statistics.median(paired), paired[0], paired[-1]))
'
