#!/usr/bin/env bash
# Start-up of `soupray render` with a cold and a warm driver program cache,
# as BENCHMARKS.md "Start-up" measures it:
#
#   scripts/startup.sh [SOUPRAY] [RUNS] [FRAMES] [-- RENDER FLAGS...]
#
# Each run renders FRAMES (default 0-4) of the shipped animation; cold runs
# start from an empty POCL_CACHE_DIR / CUDA_CACHE_PATH, warm runs reuse the
# cache the cold run filled. Prints one line per run (start-up from frame
# 0's log, the median frame total, the process wall time), then the medians
# and the frames a chunk needs for start-up to be under 5% of its time:
# startup / (startup + N * frame) < 0.05, i.e. N > 19 * startup / frame.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/soupray}
runs=${2:-3}
frames=${3:-0-4}
shift $(( $# < 3 ? $# : 3 ))
[ "${1:-}" = "--" ] && shift
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
results="$tmp/results"
for i in $(seq "$runs"); do
  for kind in cold warm; do
    [ "$kind" = cold ] && rm -rf "$tmp/cache"
    out="$tmp/$kind-$i"
    t0=$(date +%s%N)
    POCL_CACHE_DIR="$tmp/cache/pocl" CUDA_CACHE_PATH="$tmp/cache/cuda" \
      "$bin" render animations/walker/walker.glb --frames "$frames" --out "$out" --quiet "$@"
    t1=$(date +%s%N)
    python3 - "$out" "$kind" $(( (t1 - t0) / 1000000 )) <<'EOF' | tee -a "$results"
import json, pathlib, statistics, sys
out, kind, wall = pathlib.Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
logs = [json.loads(p.read_text())["timings_ms"] for p in sorted(out.glob("*.json"))]
startup = sum(t.get("startup", 0.0) for t in logs)
frame = statistics.median(t["total"] for t in logs)
print(f"{kind} startup_ms={startup:.0f} frame_total_ms={frame:.0f} wall_ms={wall} frames={len(logs)}")
EOF
  done
done
python3 - "$results" <<'EOF'
import statistics, sys
rows = [dict(kv.split("=") for kv in line.split()[1:]) | {"kind": line.split()[0]}
        for line in open(sys.argv[1])]
for kind in ("cold", "warm"):
    r = [x for x in rows if x["kind"] == kind]
    s = statistics.median(float(x["startup_ms"]) for x in r)
    f = statistics.median(float(x["frame_total_ms"]) for x in r)
    n = int(19 * s / f) + 1
    print(f"{kind}: median startup {s:.0f} ms, median frame {f:.0f} ms, "
          f"chunk of >= {n} frames for start-up under 5%")
EOF
