#!/usr/bin/env bash
# Renders the outputs a restructuring must keep bit-identical into DIR with the dofcache
# executable EXE: render (drt with the default cache, and preview-occlusion) on the five peer
# scenes at 160x120 with 2 threads, and a 4-frame persistent sequence of the dolly with its cache
# file; statistics JSON with the timing fields removed.
# Usage: bench/identity/render_outputs.sh EXE DIR [SOURCE_DIR]; then
#        python3 bench/identity/compare_outputs.py DIR_BEFORE DIR_AFTER
set -euo pipefail
exe="$1"; dir="$2"; src="${3:-$(cd "$(dirname "$0")/../.." && pwd)}"
mkdir -p "$dir"
for s in cornell_box.gltf color_bars.gltf color_spheres.gltf glossy_closeup.glb hanging_light_box.gltf; do
  n="${s%.*}"
  "$exe" render "$src/scenes/$s" --width 160 --height 120 --threads 2 -q \
    --out "$dir/$n-drt.exr" --stats-json "$dir/$n-drt.json" >/dev/null
  "$exe" render "$src/scenes/$s" --width 160 --height 120 --threads 2 -q --mode preview-occlusion \
    --out "$dir/$n-preview.exr" --save-preview-inputs "$dir/$n-inputs.exr" \
    --stats-json "$dir/$n-preview.json" >/dev/null
done
"$exe" sequence "$src/scenes/cornell_box_dolly.gltf" --frames 0-3 --width 160 --threads 2 -q \
  --persistent --out "$dir/dolly/####.exr" --cache-out "$dir/dolly-cache.vdb" \
  --stats-json "$dir/dolly.json" >/dev/null
