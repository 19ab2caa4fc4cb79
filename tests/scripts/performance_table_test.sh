#!/usr/bin/env bash
# scripts/performance_table.py on a hand-made Google Benchmark JSON: rows are grouped by
# stage and figure, Google Benchmark's suffixes dropped, medians taken from aggregates,
# times put in ms, ratios to the floor and the peer computed; names outside the stage
# groups left out. Fails on any difference from the expected table.
set -euo pipefail
script=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cat >"$dir/results.json" <<'JSON'
{"context": {"date": "2026-12-02T17:00:00", "host_name": "ci", "num_cpus": 2, "mhz_per_cpu": 3000,
             "load_avg": [0.5, 0.4, 0.3], "library_build_type": "release"},
 "benchmarks": [
  {"name": "hdr/merge/ours/real_time_median", "run_name": "hdr/merge/ours/real_time", "run_type": "aggregate",
   "aggregate_name": "median", "real_time": 6.0, "time_unit": "ms"},
  {"name": "hdr/merge/ours/real_time_mean", "run_name": "hdr/merge/ours/real_time", "run_type": "aggregate",
   "aggregate_name": "mean", "real_time": 99.0, "time_unit": "ms"},
  {"name": "hdr/merge/floor/real_time_median", "run_name": "hdr/merge/floor/real_time", "run_type": "aggregate",
   "aggregate_name": "median", "real_time": 2000.0, "time_unit": "us"},
  {"name": "hdr/merge/peer:cv::MergeDebevec/manual_time_median", "run_name": "hdr/merge/peer:cv::MergeDebevec/manual_time",
   "run_type": "aggregate", "aggregate_name": "median", "real_time": 120.0, "time_unit": "ms"},
  {"name": "sampling/prepare/ours:q2tree/300_median", "run_name": "sampling/prepare/ours:q2tree/300", "run_type": "aggregate",
   "aggregate_name": "median", "real_time": 500.0, "time_unit": "ns"},
  {"name": "Live_Latency_median", "run_name": "Live_Latency", "run_type": "aggregate",
   "aggregate_name": "median", "real_time": 1.0, "time_unit": "ms"}
 ]}
JSON
printf '# head\n' >"$dir/head.md"
python3 "$script" "$dir/results.json" "$dir/head.md" >"$dir/out.md"
cat >"$dir/expected.md" <<'MD'
# head

Measured 2026-12-02T17:00:00 on ci: 2 CPUs at 3000 MHz, load average 0.50 at the start; lightprobe built Release, wall-clock medians of the repetitions.

## hdr

| figure | ours | time | floor | × floor | peer | peer time | peer ÷ ours |
|---|---|---:|---:|---:|---|---:|---:|
| merge | lightprobe | 6.00 ms | 2.00 ms | 3.0 | cv::MergeDebevec | 120 ms | 20.00 |

## sampling

| figure | ours | time | floor | × floor | peer | peer time | peer ÷ ours |
|---|---|---:|---:|---:|---|---:|---:|
| prepare (300) | q2tree | 0.5 µs | – | – | – | – | – |

MD
diff -u "$dir/expected.md" "$dir/out.md"
# The same run split into two files (one process per stage group, scripts/performance.sh):
# the same table, headed by the first file's context.
python3 - "$dir" <<'PY'
import json, sys
d = sys.argv[1]
run = json.load(open(f"{d}/results.json"))
hdr = [b for b in run["benchmarks"] if b["name"].startswith("hdr/")]
rest = [b for b in run["benchmarks"] if not b["name"].startswith("hdr/")]
json.dump({"context": run["context"], "benchmarks": hdr}, open(f"{d}/hdr.json", "w"))
json.dump({"context": {"date": "later", "host_name": "other"}, "benchmarks": rest}, open(f"{d}/rest.json", "w"))
PY
python3 "$script" "$dir/hdr.json" "$dir/rest.json" "$dir/head.md" >"$dir/out2.md"
diff -u "$dir/expected.md" "$dir/out2.md"
echo "performance_table: as expected"
