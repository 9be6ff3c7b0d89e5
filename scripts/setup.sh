#!/usr/bin/env bash
# Installs what soupray needs on Debian/Ubuntu: an OpenCL driver (PoCL, which
# runs the kernels on the CPU), the OpenCL ICD loader to link against, and a C
# toolchain for the crates' build scripts. Idempotent; uses sudo when not root.
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
echo "setup: OpenCL devices:"
clinfo -l || true
