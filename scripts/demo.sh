#!/usr/bin/env bash
# The main job on the project's own default data: render the procedural scene (sky, a
# small very bright sun, windows and a lamp), inspect it, turn it into lights with every
# method, chart speed against accuracy, and run the live chain on dynamic sequences.
# Outputs land in ./out.
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
# Calibration: chessboard views rendered through a known 190 deg fisheye, calibrated with
# model selection by cross-validation (table printed; pictures of residuals and coverage).
$lp synth boards --views 10 -o out/boards
$lp calib geometric out/boards/board_*.png --board 9x6 --square 30 -o out/camera.yaml
# HDR: a 3-exposure bracket of the scene through a gamma camera, fused with a response
# recovered from the bracket itself, scored against OpenCV.
$lp synth bracket scene --response gamma -o out/bracket
$lp hdr fuse out/bracket/frame_0*.png --exposure-times out/bracket/exposures.csv -o out/bracket_fused.exr
$lp eval hdr scene -o out/hdr
# Probes: a mirror ball ray-traced from the scene, found, unwrapped and turned into lights.
$lp synth probe scene --type mirrorball --size 512x512 -o out/ball.exr
$lp probe unwrap out/ball.exr --type mirrorball --layout latlong --size 512x256 --fill -o out/ball_latlong.exr
$lp sample out/ball_latlong.exr --method q2tree --n 128 -o out/ball_lights.json --overlay out/ball_lights.png
$lp preview out/ball.exr -o out/ball.png
# Live sequences: a light moving across the scene, sampled frame by frame with hemigon's
# FIR filters, then every method on every dynamic scenario (flicker, jitter, lag).
$lp synth sequence --scenario moving-light --frames 24 -o out/sequence
$lp sample out/sequence --method hemigon --n 300 -o out/sequence_lights.ndjson
$lp eval temporal scene --frames 32 -o out/temporal
# Rendering with the map itself: MIS, BIS and SMC estimators on dynamic scenarios (quick run).
$lp eval estimators scene --quick -o out/estimators
# Many lights in a renderer: the angular-region, glossy and cluster tables, and what they buy.
$lp tables out/scene.exr --n 1024 -o out/tables.lpst
$lp eval shading scene --n 256,1024 -o out/shading
# No probe: a camera's metadata along a walk through a synthetic room, against real probes.
$lp synth walkthrough -o out/walkthrough
$lp estimate metadata out/walkthrough/track.jsonl -o out/metadata_model.json
$lp estimate query out/metadata_model.json --at 4,3 -o out/metadata_lights.json
$lp eval metadata out/walkthrough -o out/metadata
# Live: the whole chain from Aravis' simulated bracketing camera to the light server, 3 s.
$lp stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --listen 127.0.0.1:0 --duration 3
echo "demo: results in out/ (scene.exr, lights_*.png, eval/sampling.svg, hdr/hdr.svg, ball.png, ball_lights.png, sequence_lights.ndjson, temporal/temporal.svg, estimators/estimators.svg, shading/shading.svg, metadata/metadata.svg)"
