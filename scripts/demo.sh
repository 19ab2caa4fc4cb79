#!/usr/bin/env bash
# The main job on the project's own default data: render the procedural scene (sky, a
# small very bright sun, windows and a lamp), inspect it, turn it into lights with every
# method, and chart speed against accuracy. Outputs land in ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
lp=build/cli/lightprobe
mkdir -p out
$lp synth scene -o out/scene.exr --size 1024x512
$lp info out/scene.exr
for m in pharr hemigon q2tree mediancut; do
  $lp sample out/scene.exr --method $m --n 256 -o out/lights_$m.json --overlay out/lights_$m.png
done
$lp sample out/scene.exr --method q2tree --n auto --target-error 0.01 -o out/lights_auto.json
$lp eval sampling scene --methods all --n 16,64,256,1024 -o out/eval
echo "demo: results in out/ (scene.exr, lights_*.json, lights_*.png, eval/sampling.svg)"
