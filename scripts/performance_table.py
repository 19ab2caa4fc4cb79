#!/usr/bin/env python3
"""Google Benchmark JSON (the stage groups of bench/stages_bench.cpp) -> docs/performance.md.

Names are <stage>/<figure>/<role>[/<arg>...]: role `ours[:variant]`, `floor[:variant]` or
`peer:<name>`. One row per figure, argument and variant of ours, beside the figure's floor
and peers measured in the same run (same arguments). A variant with a floor of its own
(`floor:8-bit frames` for `ours:8-bit frames`, and for `ours:8-bit frames, 1 thread`) is
shown against it, and on a second line against the figure's floor. Medians of the repetitions when the
run has them. Standard library only (the system Python, see DEPENDENCIES.md).

    performance_table.py RESULTS.json [RESULTS.json ...] HEADER.md > docs/performance.md

Several results files (one process per stage group) are read as one run; the first one's
context (date, machine, load) heads the table.
"""
import json
import re
import sys

STAGES = ["hdr", "probe", "sampling", "calib", "live", "eval", "startup"]
# Suffixes Google Benchmark appends to a name; not part of the figure.
RUN_SUFFIX = re.compile(r"^(real_time|manual_time|process_time|iterations:\d+|repeats:\d+|threads:\d+|min_time:.*)$")
TO_MS = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}


def parse(name):
    parts = [p for p in name.split("/") if not RUN_SUFFIX.match(p)]
    if len(parts) < 3 or parts[0] not in STAGES:
        return None
    stage, figure, role, args = parts[0], parts[1], parts[2], parts[3:]
    return stage, figure + ("" if not args else " (" + ", ".join(args) + ")"), role


def load(path):
    with open(path) as f:
        data = json.load(f)
    times = {}  # (stage, figure, role) -> ms
    aggregated = any(b.get("run_type") == "aggregate" for b in data["benchmarks"])
    for b in data["benchmarks"]:
        if b.get("error_occurred"):
            continue
        if aggregated and b.get("aggregate_name") != "median":
            continue
        key = parse(b.get("run_name", b["name"]))
        if key:
            times[key] = b["real_time"] * TO_MS[b.get("time_unit", "ns")]
    return data.get("context", {}), times


def fmt_ms(ms):
    if ms is None:
        return "–"
    if ms >= 100:
        return f"{ms:.0f} ms"
    if ms >= 1:
        return f"{ms:.2f} ms"
    return f"{ms * 1e3:.1f} µs"


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: performance_table.py RESULTS.json [RESULTS.json ...] HEADER.md")
    context, times = load(sys.argv[1])
    for path in sys.argv[2:-1]:
        times.update(load(path)[1])
    with open(sys.argv[-1]) as f:
        sys.stdout.write(f.read())
    cpu = f"{context.get('num_cpus', '?')} CPUs at {context.get('mhz_per_cpu', '?')} MHz"
    load_avg = context.get("load_avg", [])
    print(f"\nMeasured {context.get('date', '?')} on {context.get('host_name', '?')}: {cpu}"
          + (f", load average {load_avg[0]:.2f} at the start" if load_avg else "")
          + "; lightprobe built Release, wall-clock medians of the repetitions.\n")
    for stage in STAGES:
        figures = sorted({(f) for (s, f, r) in times if s == stage})
        if not figures:
            continue
        print(f"## {stage}\n")
        print("| figure | ours | time | floor | × floor | peer | peer time | peer ÷ ours |")
        print("|---|---|---:|---:|---:|---|---:|---:|")
        for figure in figures:
            roles = {r: t for (s, f, r), t in times.items() if s == stage and f == figure}
            floor = roles.get("floor")
            own_floors = {r[6:]: t for r, t in roles.items() if r.startswith("floor:")}
            peers = sorted((r[5:], t) for r, t in roles.items() if r.startswith("peer:"))
            ours = sorted((r, t) for r, t in roles.items() if r == "ours" or r.startswith("ours:"))
            for role, t in ours:
                variant = "lightprobe" if role == "ours" else role[5:]
                # The longest floor variant that starts the ours variant ("8-bit frames" for
                # "8-bit frames, 1 thread"), else the figure's floor.
                own = max((v for v in own_floors if variant.startswith(v)), key=len, default=None)
                first_floor = own_floors[own] if own else floor
                floor_cell = fmt_ms(first_floor) + (f" ({own})" if own else "")
                peer_name, peer_t = peers[0] if peers else ("–", None)
                print(f"| {figure} | {variant} | {fmt_ms(t)} | {floor_cell} | "
                      f"{'–' if first_floor is None else f'{t / first_floor:.1f}'} | {peer_name} | {fmt_ms(peer_t)} | "
                      f"{'–' if peer_t is None else f'{peer_t / t:.2f}'} |")
                if own and floor is not None:
                    print(f"| | | | {fmt_ms(floor)} (floor) | {t / floor:.1f} | | | |")
                for name, pt in peers[1:]:
                    print(f"| | | | | | {name} | {fmt_ms(pt)} | {pt / t:.2f} |")
        print()


if __name__ == "__main__":
    main()
