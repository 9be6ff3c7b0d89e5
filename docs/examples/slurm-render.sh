#!/bin/bash
#SBATCH --job-name=soupray-walk
#SBATCH --array=0-9            # 10 tasks
#SBATCH --cpus-per-task=2
#SBATCH --output=logs/%x-%A_%a.out
# Frames FIRST..LAST in chunks of CHUNK; task N renders chunk N.
set -euo pipefail
SCENE=${SCENE:-animations/walker/walker.glb}
OUT=${OUT:-out/walk}
FIRST=${FIRST:-0}
LAST=${LAST:-49}
CHUNK=${CHUNK:-5}
start=$(( FIRST + SLURM_ARRAY_TASK_ID * CHUNK ))
end=$(( start + CHUNK - 1 ))
(( end > LAST )) && end=$LAST
(( start > LAST )) && exit 0
# SOUPRAY_ARGS: any further flags, e.g. "--width 1920 --height 1080 --png".
# shellcheck disable=SC2086
exec soupray render "$SCENE" --start "$start" --end "$end" \
     --out "$OUT" --skip-existing --spp "${SPP:-64}" --seed 1 ${SOUPRAY_ARGS:-}
