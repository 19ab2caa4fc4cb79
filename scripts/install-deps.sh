#!/usr/bin/env bash
# Installs the Debian 12 packages lightprobe builds with, only those missing.
# Run as root (or with sudo available). Package notes: ../shared/DEPENDENCIES.md.
set -euo pipefail

packages=(
  cmake ninja-build pkg-config g++ ccache
  libopencv-dev libopenexr-dev libimath-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev libtbb-dev libeigen3-dev
  libchealpix-dev libexiv2-dev libraw-dev libceres-dev
  libaravis-dev libusb-1.0-0-dev aravis-tools aravis-tools-cli libcamera-dev libcpp-httplib-dev
  libgtest-dev libgmock-dev libbenchmark-dev libmrcal-dev python3-mrcal libmrgingham-dev
  # zlib (the .npz inside a .cameramodel); mrcal's command-line tools, which a consumer test
  # runs on the models calib geometric writes (ctest consumers.mrcal)
  zlib1g-dev mrcal
  # libpng and libjpeg-turbo: PNG and JPEG camera images read (PNG also written) without
  # loading OpenCV's codecs plugin (core/image_io.cpp, core/picture_io.cpp)
  libpng-dev libjpeg62-turbo-dev
  # Google Highway: the vector kernels of the merge and the unwrap (hdr/merge_kernel.cpp,
  # probe/remap_kernel.cpp), compiled for SSE4/AVX2/AVX-512 and chosen at run time, so that
  # one portable binary runs them at the speed of the CPU it finds
  libhwy-dev
  # whole-system tests: private network namespaces, a load generator, a headless browser,
  # an HTTP client for abusive requests, Prometheus' linter (promtool) for /metrics
  iproute2 util-linux wrk chromium curl prometheus
  # fuzzing and the sanitizer build (scripts/fuzz.sh, scripts/sanitize.sh): clang with
  # libFuzzer and the ASan/UBSan runtimes, llvm-symbolizer for readable reports
  clang-14 libclang-rt-14-dev llvm-14
  # MQTT: the client library `stream --publish` / `merge --subscribe` use, and the broker
  # and command-line clients their tests run on loopback (openssl makes the TLS test certificates)
  libmosquitto-dev mosquitto mosquitto-clients openssl
  # OpenEXR's and OpenImageIO's tools: exrenvmap checks the prefiltered cube's frame,
  # exrheader / iinfo read what the project writes
  openexr openimageio-tools
  # Blender, headless, imports the glTF/GLB exports in a consumer test (ctest consumers.blender)
  blender
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Export checks: Khronos' glTF validator and three.js run on node (scripts/install-js-tools.sh).
# Debian's nodejs and npm only where no node is installed: a machine with another build of
# node (npm bundled with it) would see Debian's npm conflict with it.
command -v npm >/dev/null || missing+=(nodejs npm)
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}" >&2
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# JavaScript consumers for the export tests (glTF validator, three.js): project-local.
"$(dirname "$0")/install-js-tools.sh"
