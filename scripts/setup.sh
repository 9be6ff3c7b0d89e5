#!/usr/bin/env bash
# Installs what soupray needs on Debian/Ubuntu: an OpenCL driver (PoCL, which
# runs the kernels on the CPU), the OpenCL ICD loader to link against, a C
# toolchain for the crates' build scripts, and Intel Open Image Denoise for
# --denoise (below). Idempotent; uses sudo when not root.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
need=()
for pkg in pocl-opencl-icd ocl-icd-opencl-dev clinfo build-essential pkg-config; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${need[@]}"
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo is not installed. Install Rust 1.90 or newer (https://rustup.rs), then run this again." >&2
  exit 1
fi

# Intel Open Image Denoise 2.x, for `soupray render --denoise` only (soupray
# loads it at run time and works without it): the official OIDN binaries
# shipped in the pyoidn wheel, unpacked by pip into soupray's data directory,
# where soupray looks for them (src/denoise.rs). --target installs outside
# Python's site-packages, so it needs no virtualenv and is not refused by
# Debian's externally managed Python; --no-deps skips pyoidn's Python
# dependencies (numpy, cffi), which soupray does not use. The SYCL and HIP
# device modules and the command-line tools are removed (CPU and CUDA stay).
# SOUPRAY_SKIP_OIDN=1 skips this step.
oidn_version=2.5.1.0
oidn_dir="${XDG_DATA_HOME:-$HOME/.local/share}/soupray/pyoidn"
oidn_lib="$oidn_dir/pyoidn/oidn/lib/libOpenImageDenoise.so.2"
if [ -n "${SOUPRAY_SKIP_OIDN:-}" ]; then
  echo "setup: SOUPRAY_SKIP_OIDN is set: not installing Open Image Denoise (--denoise will fail)"
elif [ -e "$oidn_lib" ] && [ -e "$oidn_dir/.pyoidn-$oidn_version" ]; then
  echo "setup: Open Image Denoise: $oidn_lib"
else
  if ! python3 -m pip --version >/dev/null 2>&1; then
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq --no-install-recommends python3-pip
  fi
  rm -rf "$oidn_dir.tmp"
  python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore --no-deps --no-compile \
    --target "$oidn_dir.tmp" "pyoidn==$oidn_version"
  lib="$oidn_dir.tmp/pyoidn/oidn/lib"
  rm -rf "$oidn_dir.tmp/pyoidn/oidn/bin" "$lib"/libOpenImageDenoise_device_{sycl,hip}.* \
    "$lib"/libsycl.* "$lib"/libur_* "$lib"/libumf.*
  touch "$oidn_dir.tmp/.pyoidn-$oidn_version"
  rm -rf "$oidn_dir"
  mv "$oidn_dir.tmp" "$oidn_dir"
  echo "setup: installed Open Image Denoise (pyoidn $oidn_version): $oidn_lib"
fi

echo "setup: OpenCL devices:"
clinfo -l || true
