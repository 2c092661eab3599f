#!/usr/bin/env python3
"""Turns `plexus-bench peers --json` output (stdin) into the Markdown table of docs/BENCHMARKS.md:
one line per scenario, size and system, with every peer's ratio to Plexus.

Ratios: for latency, peer / Plexus (above 1: Plexus is faster); for msgs/s, peer / Plexus
(below 1: Plexus carries more)."""
import json
import sys


def size_label(size):
    if size >= 1 << 20 and size % (1 << 20) == 0:
        return f"{size >> 20} MiB"
    if size >= 1024 and size % 1024 == 0:
        return f"{size >> 10} KiB"
    return f"{size} B"


def main():
    rows = [json.loads(line) for line in sys.stdin if line.strip().startswith("{")]
    plexus = {(r["scenario"], r["size"]): r for r in rows if r["system"] == "plexus"}
    print("| scenario | size | system | p50 µs | p99 µs | p99.9 µs | msgs/s | MB/s | lost | server CPU µs/msg "
          "| RSS MB | p50 vs Plexus | msgs/s vs Plexus |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        base = plexus.get((r["scenario"], r["size"]))
        p50_ratio = f'{r["p50_us"] / base["p50_us"]:.2f}×' if base and base["p50_us"] else "—"
        rate_ratio = f'{r["msgs_per_s"] / base["msgs_per_s"]:.2f}×' if base and base["msgs_per_s"] else "—"
        if r["system"] == "plexus":
            p50_ratio = rate_ratio = "1"
        print(f'| {r["scenario"]} | {size_label(r["size"])} | {r["system"]} | {r["p50_us"]:.1f} | {r["p99_us"]:.1f} '
              f'| {r["p999_us"]:.1f} | {r["msgs_per_s"]:,.0f} | {r["mb_per_s"]:.1f} | {r["lost"]:.0f} '
              f'| {r["cpu_us_per_msg"]:.2f} | {r["rss_mb"]:.1f} | {p50_ratio} | {rate_ratio} |')


if __name__ == "__main__":
    main()
