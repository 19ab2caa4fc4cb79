#!/usr/bin/env bash
# The lights + SH9 table of docs/sampling.md: for each map and n, `sample --residual sh9
# --json` scores n lights + SH9 of the residual, n lights alone and SH9 alone with the
# CONVENTIONS yardstick. Prints CSV: map,method,n,light_share,then diffuse/glossy10/
# glossy100/shadowed for each of the three.
# Usage: scripts/measure-ambient.sh LIGHTPROBE METHOD MAP...   ("scene": the procedural scene)
set -euo pipefail
LP=$1; METHOD=$2; shift 2
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
echo "map,method,n,light_share,both_diffuse,both_glossy10,both_glossy100,both_shadowed,lights_diffuse,lights_glossy10,lights_glossy100,lights_shadowed,sh9_diffuse,sh9_glossy10,sh9_glossy100,sh9_shadowed"
for map in "$@"; do
  file=$map
  if [ "$map" = scene ]; then
    file=$WORK/scene.exr
    "$LP" --no-progress synth scene -o "$file" --size 1024x512 >/dev/null
  fi
  for n in 1 2 4 8 16 64; do
    "$LP" --no-progress sample --json "$file" --method "$METHOD" --n "$n" --residual sh9 --light-cap 5 -o "$WORK/l.json" 2>/dev/null |
      /usr/bin/python3 -c '
import json, sys
r = json.load(sys.stdin)
row = [sys.argv[1], sys.argv[2], sys.argv[3], "%.4f" % r["light_power_share"]]
for k in ("error", "error_lights_only", "error_sh9_only"):
    e = r[k]
    row += ["%.5f" % v for v in (e["diffuse"], e["glossy"][0], e["glossy"][1], e["shadowed"])]
print(",".join(row))' "$(basename "${map%.*}")" "$METHOD" "$n"
  done
done
