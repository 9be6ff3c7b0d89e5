#!/usr/bin/env bash
# The whole device check as one command, prepared here and run on a GPU
# machine that has no Rust toolchain and no network.
#
#   scripts/gpu-check.sh --bundle DIR   # here: build, and gather into DIR (<= 64 MiB)
#   DIR/run.sh [OUT]                    # there: the check; results under OUT
#                                       # (default ./gpu-check-out), in < 8 minutes
#
# --bundle builds the release binary, the device test binaries (cargo test
# --release --no-run) and the benchmark binaries, strips them, and copies
# the OpenCL ICD loader from Debian's ocl-icd-libopencl1 package (apt-get
# download + dpkg-deb -x), the assets the binaries read (the shared folder's assets,
# tests/golden, the shipped animation) and this script.
#
# run.sh finds the machine's OpenCL drivers (libnvidia-opencl.so.1, or any
# vendor ICD under /etc/OpenCL/vendors and the usual library directories),
# writes a vendors directory for them and points OCL_ICD_VENDORS at it
# (Debian's loader ignores OCL_ICD_FILENAMES), puts the bundled loader on
# LD_LIBRARY_PATH, and then, each step under its own timeout so that one hang
# cannot eat the budget: lists the devices; runs the device-against-reference
# tests (the builder bit for bit in both mappings, the soup, traversal hit
# for hit, golden images; with SOUPRAY_BVH_MAPPING set to each mapping in
# turn); times `soupray bvh` on the build benchmark's 1M and 2.5M-triangle
# soups in both mappings; runs the ray-throughput (camera, bounce and
# shadow rays) and path-tracing benchmarks; renders the shipped animation. Everything, with the device, the driver
# version and the programs' build logs, goes under OUT; OUT/summary.txt
# lists each step, its status and time. Exit status: 0 when every step
# passed, 1 otherwise.
#
# Environment for run.sh: GPU_CHECK_BUDGET (seconds, default 450),
# GPU_CHECK_FRAMES (frames of the animation to render, default 0-48),
# SOUPRAY_DEVICE (which device; default: the first GPU, else the first).
set -uo pipefail

usage() {
  sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
}

# ---------------------------------------------------------------- bundle ---
bundle() {
  set -e
  local dir=$1
  local repo
  repo=$(cd "$(dirname "$0")/.." && pwd)
  cd "$repo"
  command -v cargo >/dev/null || { echo "gpu-check: --bundle needs cargo (it builds here)" >&2; exit 1; }
  mkdir -p "$dir"
  dir=$(cd "$dir" && pwd)
  case "$dir/" in "$repo/"*) echo "gpu-check: put the bundle outside the checkout ($dir)" >&2; exit 2 ;; esac
  rm -rf "$dir/bin" "$dir/tests" "$dir/bench" "$dir/lib" "$dir/root"
  mkdir -p "$dir/bin" "$dir/tests" "$dir/bench" "$dir/lib" "$dir/root"

  echo "gpu-check: cargo build --release" >&2
  cargo build --release --locked --quiet
  cp target/release/soupray "$dir/bin/"

  # The device-against-reference tests, as release test binaries. Their
  # paths come from cargo's JSON messages (the file names carry a hash).
  local tests=(bvh_device soup_device trace_device golden texture_device render_reference)
  local benches=(trace_primary render_spp)
  local args=() t
  for t in "${tests[@]}"; do args+=(--test "$t"); done
  echo "gpu-check: cargo test --release --no-run (${tests[*]})" >&2
  local json
  json=$(cargo test --release --locked --no-run --message-format=json "${args[@]}")
  args=()
  for t in "${benches[@]}"; do args+=(--bench "$t"); done
  echo "gpu-check: cargo bench --no-run (${benches[*]})" >&2
  json+=$'\n'$(cargo bench --locked --no-run --message-format=json "${args[@]}")
  for t in "${tests[@]}" "${benches[@]}"; do
    local exe
    exe=$(printf '%s\n' "$json" | grep '"reason":"compiler-artifact"' \
      | grep "\"name\":\"$t\"" | grep -o '"executable":"[^"]*"' | tail -1 | cut -d'"' -f4)
    [ -n "$exe" ] && [ -x "$exe" ] || { echo "gpu-check: no executable for $t" >&2; exit 1; }
    case " ${tests[*]} " in
      *" $t "*) cp "$exe" "$dir/tests/$t" ;;
      *) cp "$exe" "$dir/bench/$t" ;;
    esac
  done
  # Symbols are kept (backtraces name functions); debug info is dropped.
  strip --strip-debug "$dir"/bin/* "$dir"/tests/* "$dir"/bench/*

  # The OpenCL ICD loader, from Debian's package, so the GPU machine's own
  # loader (or its absence) does not matter. Only the drivers come from there.
  echo "gpu-check: OpenCL ICD loader from ocl-icd-libopencl1" >&2
  local tmp
  tmp=$(mktemp -d)
  if (cd "$tmp" && apt-get download ocl-icd-libopencl1 >/dev/null 2>&1); then
    dpkg-deb -x "$tmp"/ocl-icd-libopencl1_*.deb "$tmp/x"
    cp -a "$tmp"/x/usr/lib/*/libOpenCL.so.1* "$dir/lib/"
    dpkg-deb -f "$tmp"/ocl-icd-libopencl1_*.deb Package Version > "$dir/lib/ocl-icd.version"
  else
    echo "gpu-check: apt-get download ocl-icd-libopencl1 failed (no apt lists or network?)" >&2
    rm -rf "$tmp"
    exit 1
  fi
  rm -rf "$tmp"

  # What the binaries read, under the root they are pointed at
  # (SOUPRAY_TEST_ROOT stands in for the checkout they were built in).
  # The third-party assets come from the shared folder beside the checkout
  # (the repository has no copies); the GPU machine has no other.
  shared="${SOUPRAY_SHARED:-../shared}"
  mkdir -p "$dir/root/tests" "$dir/root/animations" "$dir/shared/meshes"
  cp -a tests/golden "$dir/root/tests/"
  cp -a animations/walker "$dir/root/animations/"
  if [ -d "$shared/assets" ]; then
    cp -a "$shared/assets" "$dir/shared/"
    cp -a "$shared/meshes/beast.ply" "$shared/meshes/nefertiti.ply" "$dir/shared/meshes/"
  else
    echo "gpu-check: no shared folder at $shared: the bundle's tests that need it will skip" >&2
  fi
  cp "$0" "$dir/gpu-check.sh"
  chmod +x "$dir/gpu-check.sh"
  cat > "$dir/run.sh" <<'EOF'
#!/usr/bin/env bash
# The GPU device check: ./run.sh [OUT] (see gpu-check.sh).
exec "$(dirname "$0")/gpu-check.sh" --run "$@"
EOF
  chmod +x "$dir/run.sh"
  {
    echo "soupray gpu-check bundle"
    echo "commit: $(git rev-parse HEAD 2>/dev/null)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')"
    echo "built: $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -srm), $(rustc --version 2>/dev/null)"
    echo "loader: $(tr '\n' ' ' < "$dir/lib/ocl-icd.version")"
  } > "$dir/MANIFEST"
  (cd "$dir" && find . -type f ! -name MANIFEST -printf '%s %p\n' | sort -k2) >> "$dir/MANIFEST"

  local bytes limit=$((64 * 1024 * 1024))
  bytes=$(du -sb "$dir" | cut -f1)
  echo "gpu-check: bundle $dir: $bytes bytes ($((bytes / 1024 / 1024)) MiB of at most 64)" >&2
  if [ "$bytes" -gt "$limit" ]; then
    echo "gpu-check: the bundle is over 64 MiB" >&2
    exit 1
  fi
}

# ------------------------------------------------------------------- run ---
run_check() {
  local B
  B=$(cd "$(dirname "$0")" && pwd)
  [ -x "$B/bin/soupray" ] || { echo "gpu-check: --run works from a bundle (scripts/gpu-check.sh --bundle DIR)" >&2; exit 2; }
  OUT=${1:-${OUT:-$PWD/gpu-check-out}}
  mkdir -p "$OUT"
  OUT=$(cd "$OUT" && pwd)
  local started=$SECONDS budget=${GPU_CHECK_BUDGET:-450}
  local summary="$OUT/summary.txt" failed=0
  : > "$summary"
  # The summary file is the record; the terminal copy may go away (a closed
  # pipe, a dropped ssh session) without stopping the check.
  trap '' PIPE HUP
  note() { echo "$*" >> "$summary"; echo "$*" >&2 2>/dev/null || true; }

  # Drivers: every ICD the machine has, NVIDIA's first.
  local vendors="$OUT/vendors"
  rm -rf "$vendors"
  mkdir -p "$vendors"
  local lib d f n=0
  for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib /usr/local/nvidia/lib64 \
           /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu/nvidia/current \
           /run/nvidia/driver/usr/lib/x86_64-linux-gnu /usr/local/cuda/lib64 \
           /usr/local/cuda/compat; do
    if [ -e "$d/libnvidia-opencl.so.1" ]; then
      echo "$d/libnvidia-opencl.so.1" > "$vendors/00-nvidia.icd"
      break
    fi
  done
  if [ ! -e "$vendors/00-nvidia.icd" ] && command -v ldconfig >/dev/null; then
    lib=$(ldconfig -p 2>/dev/null | awk '/libnvidia-opencl\.so\.1 / {print $NF; exit}')
    [ -n "$lib" ] && echo "$lib" > "$vendors/00-nvidia.icd"
  fi
  for f in /etc/OpenCL/vendors/*.icd ${OCL_ICD_VENDORS:+"$OCL_ICD_VENDORS"/*.icd}; do
    [ -f "$f" ] || continue
    lib=$(head -n1 "$f")
    case "$lib" in *libnvidia-opencl*) [ -e "$vendors/00-nvidia.icd" ] && continue ;; esac
    n=$((n + 1))
    echo "$lib" > "$vendors/$(printf '%02d' "$n")-$(basename "$f")"
  done
  export OCL_ICD_VENDORS=$vendors
  export LD_LIBRARY_PATH="$B/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export SOUPRAY_TEST_ROOT="$B/root"
  export SOUPRAY_SHARED="$B/shared"
  export SOUPRAY_BUILD_LOG_DIR="$OUT/build-logs"
  # The drivers' program caches, inside OUT: the first program builds are
  # cold, as on a fresh node; later ones hit the cache.
  export CUDA_CACHE_PATH="$OUT/cache/cuda" POCL_CACHE_DIR="$OUT/cache/pocl"
  export RUST_BACKTRACE=1
  mkdir -p "$SOUPRAY_BUILD_LOG_DIR" "$OUT/tests" "$OUT/bench" "$OUT/bvh"
  note "gpu-check on $(hostname) at $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  note "bundle: $(sed -n 2,4p "$B/MANIFEST" | tr '\n' ';')"
  note "ICDs: $(for f in "$vendors"/*.icd; do [ -f "$f" ] && printf '%s ' "$(cat "$f")"; done)"
  [ "$(ls "$vendors" | wc -l)" -gt 0 ] || note "no OpenCL driver (ICD) found on this machine"
  # soupray opens libOpenCL.so.1 at run time (dlopen, not a link-time
  # dependency); the dynamic linker's trace says which one it got.
  note "loader used: $(LD_DEBUG=libs timeout 30 "$B/bin/soupray" devices 2>&1 >/dev/null \
    | awk '/calling init: .*libOpenCL/ {print $NF; exit}')"

  # One step: NAME, its own time limit (seconds), the command. The limit is
  # cut to what is left of the budget, keeping 10 s to write the summary.
  step() {
    local name=$1 limit=$2
    shift 2
    local left=$((budget - (SECONDS - started) - 10))
    if [ "$left" -lt 5 ]; then
      note "$(printf '%-34s %-8s' "$name" SKIPPED) (out of time)"
      failed=1
      return
    fi
    [ "$limit" -gt "$left" ] && limit=$left
    local t0=$SECONDS status rc
    timeout -k 5 "$limit" "$@" > "$OUT/logs/$name.log" 2>&1
    rc=$?
    case $rc in
      0) status=ok ;;
      124|137) status=TIMEOUT; failed=1 ;;
      *) status="FAILED($rc)"; failed=1 ;;
    esac
    note "$(printf '%-34s %-8s %4ds (limit %ds)  logs/%s.log' "$name" "$status" $((SECONDS - t0)) "$limit" "$name")"
  }
  mkdir -p "$OUT/logs"

  # Device and driver.
  if command -v nvidia-smi >/dev/null; then
    step nvidia-smi 20 nvidia-smi -q
  fi
  step devices 30 "$B/bin/soupray" devices
  step devices-json 30 sh -c '"$1" devices --json > "$2"' _ "$B/bin/soupray" "$OUT/devices.json"
  grep -E '"(name|platform|driver|version|kind|local_mem_kib|correctly_rounded_divide_sqrt)"' \
    "$OUT/devices.json" 2>/dev/null | sed 's/^ */  /' >> "$summary"

  # Device against reference. bvh_device checks both mappings itself; the
  # others run under each mapping in turn (the renderer's builder follows
  # SOUPRAY_BVH_MAPPING).
  step test-bvh_device 120 "$B/tests/bvh_device" --test-threads=2
  for t in soup_device trace_device texture_device render_reference; do
    step "test-$t" 90 "$B/tests/$t" --test-threads=2
  done
  step test-golden-paper 90 env SOUPRAY_BVH_MAPPING=paper "$B/tests/golden" --test-threads=2
  step test-golden-single-lane 90 env SOUPRAY_BVH_MAPPING=single-lane "$B/tests/golden" --test-threads=2
  [ -d "$B/root/out/golden" ] && cp -a "$B/root/out/golden" "$OUT/golden-failures"

  # Build timings: the build benchmark's 1M and 2.5M soups (10 and 25
  # copies of nefertiti.ply), both mappings, the median of 6 builds (the
  # first, which includes the kernels' first launches, does not move it).
  local mesh="$B/shared/meshes/nefertiti.ply" copies mapping
  for copies in 10 25; do
    for mapping in paper single-lane; do
      # 90 s: the paper mapping's six 2.5M builds take about 60 s on a
      # loaded 2-core PoCL, the slowest device this has to survive.
      step "bvh-${copies}x-$mapping" 90 sh -c \
        'SOUPRAY_BVH_MAPPING=$1 "$2" bvh "$3" --copies "$4" --repeat 6 --json --verbose > "$5"' \
        _ "$mapping" "$B/bin/soupray" "$mesh" "$copies" "$OUT/bvh/nefertiti-x$copies-$mapping.json"
    done
  done

  # Trace: camera, diffuse-bounce and shadow rays (Mrays/s) of the 8-wide,
  # 4-wide and binary traversals on the two scans the bundle carries (the
  # CPU reference on 8 threads), and path tracing (samples/s).
  step bench-trace_primary 90 sh -c '"$1" --runs 5 --threads 8 --meshes beast.ply,nefertiti.ply > "$2"' _ "$B/bench/trace_primary" "$OUT/bench/trace_primary.md"
  step bench-render_spp 90 sh -c '"$1" --frames 3 > "$2"' _ "$B/bench/render_spp" "$OUT/bench/render_spp.md"

  # The shipped animation, as a farm renders it: start-up in frame 0's log.
  step render 120 "$B/bin/soupray" render "$B/root/animations/walker/walker.glb" \
    --frames "${GPU_CHECK_FRAMES:-0-48}" --out "$OUT/render" --quiet
  step report 30 "$B/bin/soupray" report "$OUT/render"

  note "total $((SECONDS - started))s of a ${budget}s budget; $([ $failed = 0 ] && echo 'every step passed' || echo 'some steps FAILED')"
  note "results: $OUT"
  return $failed
}

case "${1:-}" in
  --bundle) [ $# -eq 2 ] || usage; bundle "$2" ;;
  --run) shift; run_check "$@" ;;
  *) usage ;;
esac
