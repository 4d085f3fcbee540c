#!/usr/bin/env bash
# Measures `dofcache view` through its HTTP API (docs/view.md, "Measured"): time from the command
# to the first inputs, click-to-image latency (focus at a pixel, then the preview as raw RGBA,
# as the page does), and the reference's convergence (relMSE to the preview, spp, resident memory)
# over time.
# Usage: bench/view_measure.sh DOFCACHE_EXE SECONDS [view options...]
# Prints one line per measurement; needs curl and python3.
set -euo pipefail
exe="$1"; seconds="$2"; shift 2
out="$(mktemp)"
start=$(date +%s.%N)
"$exe" view --port 0 "$@" >"$out" 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null || true; rm -f "$out"' EXIT
url=""
for _ in $(seq 300); do
  url=$(grep -o 'http://127.0.0.1:[0-9]*/?token=[0-9a-f]*' "$out" || true)
  [ -n "$url" ] && break
  sleep 0.02
done
[ -n "$url" ] || { cat "$out"; exit 1; }
base="${url%%/?token=*}"; token="${url##*token=}"
api() { curl -sf -H "X-Dofcache-Token: $token" "$@"; }
json() { python3 -c "import json,sys; d=json.load(sys.stdin); r=($1); print(*r) if isinstance(r, tuple) else print(r)"; }
printf 'address printed after %.0f ms\n' "$(echo "($(date +%s.%N) - $start) * 1000" | bc)"
# The preview is refused until the first inputs exist: poll it directly (a status poll through
# python would add its own start-up time to what is measured).
until api "$base/api/image?kind=preview&format=raw" -o /dev/null; do sleep 0.01; done
printf 'first preview fetched after %.0f ms (inputs ready %s ms after the session started)\n' \
  "$(echo "($(date +%s.%N) - $start) * 1000" | bc)" \
  "$(api "$base/api/status" | json 'round(d["first_preview_ms"])')"
read -r w h < <(api "$base/api/status" | json 'd["width"], d["height"]')
# Clicks on a 3x3 grid (skipping pixels that see nothing), each followed by the preview fetch.
for fy in 1 2 3; do
  for fx in 1 2 3; do
    x=$((w * fx / 4)); y=$((h * fy / 4))
    t=$(curl -s -o /dev/null -w '%{time_total}' -H "X-Dofcache-Token: $token" \
          -X POST -d "{\"x\": $x, \"y\": $y}" "$base/api/focus")
    t2=$(curl -s -o /dev/null -w '%{time_total} %{size_download}' -H "X-Dofcache-Token: $token" \
          "$base/api/image?kind=preview&format=raw")
    refocus=$(api "$base/api/status" | json 'round(d["last_refocus_ms"] or 0)')
    printf 'click (%d, %d): focus %.0f ms + image %.0f ms (post-process %s ms)\n' "$x" "$y" \
      "$(echo "$t * 1000" | bc)" "$(echo "${t2% *} * 1000" | bc)" "$refocus"
  done
done
# Convergence for the last lens.
t0=$(date +%s)
while [ $(( $(date +%s) - t0 )) -lt "$seconds" ]; do
  sleep 5
  s=$(api "$base/api/status")
  m=$(api "$base/api/compare" 2>/dev/null | json '"%.5f" % d["rel_mse"]' 2>/dev/null || echo "-")
  elapsed=$(( $(date +%s) - t0 ))
  echo "$s" | ELAPSED="$elapsed" REL_MSE="$m" python3 -c '
import json, os, sys
d = json.load(sys.stdin)
r = d["reference"]
print("%s s: stage %s, reference %d spp after %.1f s of rendering, relMSE(preview, reference) %s, "
      "resident %.0f MB" % (os.environ["ELAPSED"], d["stage"], r["spp"], r["seconds"],
                            os.environ["REL_MSE"], d["memory_bytes"] / 1048576))'
done
