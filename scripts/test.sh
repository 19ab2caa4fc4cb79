#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (ctest).
# Real data is read from ../shared/data beside the repository.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j "$(nproc)" --timeout 900
