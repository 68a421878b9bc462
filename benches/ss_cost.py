#!/usr/bin/env python3
"""What single scattering and the beam source terms add to the default frame's GPU time (issue 12:
"<= 20%"), from interleaved runs of `translucent render --json` (benches/RESULTS.md, "Cost of
single scattering and the source terms").

Configurations, run in turn (A, B, C, A, B, C, ...) so that the machine's load, which other work
changes, falls on all of them alike:
  all     the default frame (single scattering on, `--source second`: beam, second collision,
          upstream beam, continuation, moments exit query);
  no_ss   `--single-scattering off` (the source terms alone);
  none    `--single-scattering off --source flux --exit-query moments`: the boundary flux enters
          the same solve, read by the same exit query (no beam, no march): the frame without the
          terms.
The frame's GPU time is the sum of its top-level passes (the frame graph's passes and the
capture; nested profiler scopes, named with a space, are inside them). Prints the median per
configuration and pass, and the added share (all - none) / none.

Usage: python3 benches/ss_cost.py [--bin target/release/translucent] [--runs 7]
       [--label NAME] [-- extra render args, e.g. --width 256 --height 256 --supersample 1]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

CONFIGS = {
    "all": [],
    "no_ss": ["--single-scattering", "off"],
    "none": ["--single-scattering", "off", "--source", "flux", "--exit-query", "moments"],
}


def load():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run(binary, extra, out_dir, name):
    out = os.path.join(out_dir, f"{name}.png")
    cmd = ["nice", "-n", "10", binary, "render", "--out", out, "--json", *extra]
    result = subprocess.run(cmd, capture_output=True, text=True, check=True)
    frame = json.loads(result.stdout)["frames"][0]
    passes = {k: v for k, v in frame["passes"].items() if " " not in k}
    return passes, frame.get("multigrid", {}).get("work_units")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", default="target/release/translucent")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--out", default="target/ss-cost")
    parser.add_argument("--configs", default="all,no_ss,none")
    parser.add_argument("extra", nargs="*")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    names = args.configs.split(",")
    samples = {n: [] for n in names}
    loads = []
    work = {}
    for r in range(args.runs):
        for n in names:
            loads.append(load())
            passes, wu = run(args.bin, CONFIGS[n] + args.extra, args.out, n)
            samples[n].append(passes)
            work[n] = wu
            print(f"run {r} {n}: {sum(passes.values()):.1f} ms (load {loads[-1]:.1f})",
                  file=sys.stderr)
    pass_names = sorted({p for n in names for s in samples[n] for p in s})
    print(f"render args: {' '.join(args.extra) or '(defaults)'}; {args.runs} interleaved runs; "
          f"load {min(loads):.1f}-{max(loads):.1f} (median {statistics.median(loads):.1f})")
    print("| pass | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for p in pass_names:
        cells = [statistics.median([s.get(p, 0.0) for s in samples[n]]) for n in names]
        print(f"| {p} | " + " | ".join(f"{c:.1f}" for c in cells) + " |")
    totals = {n: statistics.median([sum(s.values()) for s in samples[n]]) for n in names}
    print("| **frame (median of sums)** | " + " | ".join(f"**{totals[n]:.1f}**" for n in names)
          + " |")
    print("| solve work units | " + " | ".join(f"{work[n]}" for n in names) + " |")
    if "all" in totals and "none" in totals:
        base = totals["none"]
        print(f"added by the terms: all/none - 1 = {100 * (totals['all'] / base - 1):.1f}%")
        # Per run pair (the same load): the ratio's median, less sensitive to drifting load.
        ratios = [sum(a.values()) / sum(b.values())
                  for a, b in zip(samples["all"], samples["none"])]
        print(f"per interleaved pair: median {100 * (statistics.median(ratios) - 1):.1f}%, "
              f"range {100 * (min(ratios) - 1):.1f}..{100 * (max(ratios) - 1):.1f}%")


if __name__ == "__main__":
    main()
