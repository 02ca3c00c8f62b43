#!/usr/bin/env bash
# The GPU figures of docs/rendering.md (section GPU), in one call on a machine with an NVIDIA
# GPU: every library scene rendered per preset on the GPU (Cycles' OptiX, else CUDA) and on
# the CPU in the same run -- seconds per stereo frame and the ratio (bench/bench_render.py,
# configurations NAME and NAME/gpu) -- then the quality rows of the GPU renders at the scene's own size in
# the centre window (bench/quality.py --device gpu: PSNR against a 4096-sample reference,
# rendered on the GPU unless out/bench-cache holds it).
#
#     bench/gpu_figures.sh [--scale 0.5] [--frames 2] [--scenes "city_kitti hall office forest paper_room"]
#                          [--presets "gt draft final"] [--no-quality] [--no-speed]
#                          [--unbiased N [--seeds 2] [--tries "NAME:base=final,samples=64 ..."]]
#
# --unbiased N: the quality rows against the truth instead of a 4096-sample reference
# (bench/quality_unbiased.py --device gpu: two N-sample references under other seeds, their
# noise subtracted; every preset but gt under --seeds seeds, and the --tries configurations);
# images and rows under $OUT/unbiased_SCENE.
#
# Every figure goes to stdout and to $OUT/gpu_figures.txt (or out/gpu_figures.txt): paste the
# tables into docs/rendering.md with the command and the machine. The CPU side costs the most:
# --scale and --frames keep it inside one call (city_kitti `final` at 0.5 is ~1 CPU min per
# stereo frame on 16 cores).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-$( [ -x .venv/bin/python ] && echo .venv/bin/python || command -v python3 )}
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
SCALE=0.5 FRAMES=2 QUALITY=1 SPEED=1 UNBIASED=0 SEEDS=2 TRIES=""
SCENES="city_kitti hall office forest paper_room" PRESETS="gt draft final"
while [ $# -gt 0 ]; do
  case $1 in
    --scale) SCALE=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --scenes) SCENES=$2; shift 2 ;;
    --presets) PRESETS=$2; shift 2 ;;
    --no-quality) QUALITY=0; shift ;;
    --no-speed) SPEED=0; shift ;;
    --unbiased) UNBIASED=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --tries) TRIES=$2; shift 2 ;;
    *) echo "gpu_figures.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
LOG=${OUT:-out}/gpu_figures.txt
mkdir -p "$(dirname "$LOG")"
{
  echo "# gpu_figures.sh --scale $SCALE --frames $FRAMES; $(date -u +%FT%TZ); $(nproc) CPUs;" \
       "$(nvidia-smi --query-gpu=name,memory.total --format=csv,noheader 2>/dev/null || echo 'no nvidia-smi')"
  "$PY" -c "from blender_sesgen.blender.render import enable_gpu; print('# Cycles device:', enable_gpu())" || exit 2
  for s in $SCENES; do
    [ "$SPEED" = 1 ] || break
    configs=()
    for p in $PRESETS; do configs+=("$p" "$p/gpu"); done
    "$PY" bench/bench_render.py --scene "scenes/$s.ses" --scale "$SCALE" --frames "$FRAMES" --configs "${configs[@]}" \
      || echo "# $s: bench_render failed"
  done
  if [ "$QUALITY" = 1 ] && [ "$UNBIASED" -gt 0 ]; then
    for s in $SCENES; do
      # shellcheck disable=SC2086  # $TRIES: one word per configuration
      "$PY" bench/quality_unbiased.py --scene "scenes/$s.ses" --scale 1 --crop 0.25 --device gpu \
        --ref-samples "$UNBIASED" --seeds "$SEEDS" --out "${OUT:-out}/unbiased_$s" \
        --configs $(echo "$PRESETS" | tr ' ' '\n' | grep -v '^gt$') ${TRIES:+--try $TRIES} \
        || echo "# $s: quality_unbiased failed"
    done
  elif [ "$QUALITY" = 1 ]; then
    for s in $SCENES; do
      "$PY" bench/quality.py --scene "scenes/$s.ses" --scale 1 --crop 0.25 --device gpu --configs $(echo "$PRESETS" | tr ' ' '\n' | grep -v '^gt$') \
        || echo "# $s: quality failed"
    done
  fi
} 2>&1 | tee "$LOG"
