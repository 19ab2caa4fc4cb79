#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, one per reader) with clang into build-fuzz/ and
# runs each for a bounded time from a small seed corpus: a handful of real files picked
# from ../shared/data at run time (never copied into the repository) plus tiny seeds
# written here. Prints per target the executions, libFuzzer's coverage figures (cov: edges,
# ft: features) and the outcome; a crash, sanitizer report, leak, timeout or out-of-memory
# fails the run (exit 1) and its input is kept in build-fuzz/findings/.
#
#   FUZZ_SECONDS=20     seconds per target
#   FUZZ_TARGETS="..."  only these targets (names as in fuzz/CMakeLists.txt: rgbe pfm ...)
#   FUZZ_JOBS=N         targets run at once (default: the number of cores)
#   FUZZ_SEED=1         libFuzzer's random seed; fixed so that a run is a gate, not a lottery:
#                       one process per target from the same seeds mutates in the same order,
#                       so CI's 20 s are a prefix of a longer local run with the same seed.
#                       FUZZ_SEED=0 draws a fresh seed (exploring; what a finding then needs
#                       is a regression test that reads the minimised input).
# Running one target longer, and reproducing a finding: docs/fuzzing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
data=$(cd .. && pwd)/shared/data
build=$root/build-fuzz
seconds=${FUZZ_SECONDS:-20}
fuzz_seed=${FUZZ_SEED:-1}
jobs=${FUZZ_JOBS:-$(nproc)}
all_targets="rgbe pfm exr camera_image cameramodel opencv_yaml opencv_xml light_list response readings_csv timestamps config http_request corners_vnl"
targets=${FUZZ_TARGETS:-$all_targets}

bash scripts/install-deps.sh
# The libraries compile exactly as in scripts/sanitize.sh's build-asan/: with the build
# directory left out of ccache's hash, whichever script runs second reuses the objects.
export CCACHE_NOHASHDIR=true
# -O1 with line tables and asserts on (no NDEBUG): cheap to build, readable reports.
CC=clang-14 CXX=clang++-14 cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DLIGHTPROBE_SANITIZE=ON -DLIGHTPROBE_BUILD_FUZZERS=ON -DLIGHTPROBE_BUILD_TESTS=OFF -DLIGHTPROBE_BUILD_BENCH=OFF >/dev/null
build_start=$SECONDS
cmake --build "$build" --target $(for t in $targets; do printf 'fuzz_%s ' "$t"; done) -j "$(nproc)"
echo "fuzz: built in $((SECONDS - build_start)) s" >&2

# ---- seeds ------------------------------------------------------------------------------
corpus=$build/corpus
rm -rf "$corpus" "$build/logs"
mkdir -p "$corpus" "$build/logs" "$build/findings" "$build/tmp"

# A handful of real files: the smallest `count` matching `pattern` under ../shared/data.
real_seeds() {  # target count find-args...
  local target=$1 count=$2
  shift 2
  [ -d "$data" ] || return 0
  find "$data" -type f \( "$@" \) -printf '%s %p\n' | sort -n | awk -v n="$count" 'NR <= n' | cut -d' ' -f2- |
    while read -r f; do cp "$f" "$corpus/$target/real-$(basename "$f")"; done
}
seed() { printf "$2" >"$corpus/$1/$3"; }  # target printf-format name

for t in $all_targets; do mkdir -p "$corpus/$t"; done
real_seeds rgbe 3 -name '*.hdr'
seed rgbe '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=2\nLIGHTPROBE_LAYOUT=latlong\n\n-Y 1 +X 2\n\x80\x40\x20\x81\x10\x10\x10\x80' flat.hdr
seed rgbe '#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n\x02\x02\x00\x08\x88\x80\x88\x40\x88\x20\x88\x81' rle.hdr
seed pfm 'PF\n2 1\n-1.0\n\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40' colour-le.pfm
seed pfm 'Pf\n2 1\n1.0\n\x3f\x80\x00\x00\x40\x00\x00\x00' grey-be.pfm
real_seeds exr 3 -name '*.exr'
real_seeds camera_image 2 -name '*.png'
real_seeds camera_image 2 -name '*.jpg'
seed cameramodel "{\n    'lensmodel':  'LENSMODEL_OPENCV8',\n    'intrinsics': [ 1000, 1000, 639.5, 479.5, -0.1, 0.01, 0, 0, 0, 0, 0, 0 ],\n    'extrinsics': [ 0, 0, 0, 0, 0, 0 ],\n    'imagersize': [ 1280, 960 ],\n}\n# rms_reprojection_px = 0.25\n" opencv8.cameramodel
seed cameramodel "{'lensmodel': 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=4_Ny=3_fov_x_deg=120', 'intrinsics': [500,500,320,240$(printf ',0%.0s' {1..24})], 'imagersize': [640,480]}\n" splined.cameramodel
real_seeds opencv_yaml 2 -name '*intrinsics.yml'
seed opencv_yaml '%%YAML:1.0\n---\nimage_width: 1280\nimage_height: 960\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 400., 0., 640., 0., 400., 480., 0., 0., 1. ]\ndistortion_model: fisheye\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n   data: [ 0.01, -0.002, 0., 0. ]\n' fisheye.yaml
seed opencv_yaml '%%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 300., 0., 320., 0., 300., 240., 0., 0., 1. ]\ndistortion_model: omnidir\nxi: 1.2\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n   data: [ 0., 0., 0., 0. ]\n' omnidir.yaml
real_seeds opencv_xml 1 -name '*.xml'
seed opencv_xml '<?xml version="1.0"?>\n<opencv_storage>\n<image_width>640</image_width>\n<image_height>480</image_height>\n<camera_matrix type_id="opencv-matrix">\n  <rows>3</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n    300. 0. 320. 0. 300. 240. 0. 0. 1.</data></camera_matrix>\n<distortion_model>plumb_bob</distortion_model>\n<distortion_coefficients type_id="opencv-matrix">\n  <rows>1</rows><cols>5</cols><dt>d</dt><data>0.1 0. 0. 0. 0.</data></distortion_coefficients>\n<!-- a comment -->\n</opencv_storage>\n' plumb_bob.xml
seed light_list '{"format": "lightprobe.lights/1", "frame": 42, "timestamp": 1700000000.123, "method": "q2tree", "units": "relative", "frame_convention": "z-up", "lights": [{"id": 17, "direction": [0, 0, 1], "rgb": [1, 2, 3], "solid_angle": 0.0123}, {"id": 18, "direction": [0.6, 0, 0.8], "rgb": [0.5, 0.5, 0.5], "solid_angle": 0.5}]}\n' list.json
seed response '{"format": "lightprobe.response/1", "levels": 4, "linear": false, "log_exposure": {"r": [-3, -1, 0, 1], "g": [-3, -1, 0, 1], "b": [-3, -1, 0, 1]}}\n' response.json
seed response '{"format": "lightprobe.response/1", "levels": 2, "linear": true}\n' linear.json
seed readings_csv '# grey card and a lux meter\nregion,camera_value,measured,unit\npatch-1,0.0213,48.2,cd/m2\npatch-2,0.0520,118,cd/m2\nlux,1.5,3400,lux\n' readings.csv
seed readings_csv 'region,camera_value,measured,unit\nimage:photo.png:10,10,4,4,,48.2,cd/m2\n' region.csv
seed corners_vnl '# filename x y level\nview1.png 10.5 20.25 0\nview1.png 30 20 0\nview1.png 50 20 1\nview1.png 10 40 0\nview1.png 30 40 0\nview1.png 50 40 0\nview2.png - - -\n' corners.vnl
seed timestamps '# capture times\n1700000000.0\n1700000000.04\n1700000000.08\n' seconds.txt
seed timestamps 'a.pfm 0.5\nb.pfm 1.0\nc.pfm 1.5\n' named.txt
seed config '[stream]\nsource = "replay:frames"\nlisten = "127.0.0.1:8080"\nmethod = "q2tree"\nn = 64\nexposures = "0.001,0.01"\nloop = true\nfps = 30.0\n' rig.toml
seed config 'json = true\n[merge]\nweights = "1,2"\ntimeout = 2.5\n' merge.toml
seed http_request 'GET /lights HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer secret\r\nIf-None-Match: W/"x"\r\n\r\n' lights.txt
seed http_request 'GET /lights/stream?format=ndjson HTTP/1.1\r\nAuthorization: Bearer secret\r\n\r\n' stream.txt
seed http_request 'HEAD /status HTTP/1.0\r\nAuthorization: Bearer secret\r\nConnection: keep-alive\r\n\r\n' status.txt
seed http_request 'GET /%%ff?access_token=x HTTP/1.1\r\nContent-Length: 0, 0\r\nExpect: 100-continue\r\n\r\n' odd.txt

# ---- runs -------------------------------------------------------------------------------
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0:intercept_tls_get_addr=0}  # see sanitize.sh
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export ASAN_SYMBOLIZER_PATH=${ASAN_SYMBOLIZER_PATH:-/usr/lib/llvm-14/bin/llvm-symbolizer}
export TMPDIR=$build/tmp

run_one() {  # target: fuzzes it, then prints one summary line
  local t=$1 log=$build/logs/$1.log rc=0
  # -close_fd_mask=3: the libraries' own chatter (OpenCV, libpng) off; libFuzzer's and the
  # sanitizers' reports still come through. -max_len: whole small seeds, headers of the rest.
  "$build/fuzz/fuzz_$t" "$corpus/$t" -max_total_time="$seconds" -seed="$fuzz_seed" -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=2048 -max_len=131072 -close_fd_mask=3 -print_final_stats=1 \
    -artifact_prefix="$build/findings/$t-" >"$log" 2>&1 || rc=$?
  local runs cov ft corpus_n
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  corpus_n=$(grep -o 'corp: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  if [ "$rc" -eq 0 ]; then
    printf 'fuzz %-13s ok      %9s runs  cov %5s  ft %6s  corpus %4s\n' "$t" "${runs:-?}" "${cov:-?}" "${ft:-?}" "${corpus_n:-?}"
  else
    local what artifact
    what=$(grep -m1 -oE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer): [^ ]+( [^ ]+)?|runtime error: .*|SUMMARY: .*' "$log" | head -1)
    artifact=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | tail -1)
    printf 'fuzz %-13s FAILED  %s\n' "$t" "${what:-exit $rc}"
    printf '  input: %s\n  log:   %s\n  again: %s %s\n' "${artifact:-?}" "$log" "$build/fuzz/fuzz_$t" "${artifact:-}"
  fi
}
export -f run_one
export build corpus seconds fuzz_seed

start=$SECONDS
summary=$build/logs/summary.txt
printf '%s\n' $targets | xargs -P "$jobs" -I{} bash -c 'run_one {}' | tee "$summary"
passed=$(grep -c ' ok ' "$summary" || true)
failed=$(grep -c ' FAILED ' "$summary" || true)
echo "fuzz: ${seconds} s per target, seed $fuzz_seed, $jobs at once, $((SECONDS - start)) s in all"
echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
