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
Each run renders `--frames F+1 --no-skip` (every frame a full cold frame, the first discarded:
it JIT-compiles what Mesa's shader cache lacks). A frame's GPU time is the sum of its top-level
passes (the frame graph's passes and the capture; nested profiler scopes, named with a space,
are inside them). The terms' cost is that of the passes they change (TERM_PASSES: the march,
its depth pre-pass, gather_q less its cost in `none`); the frame without them is the passes
every configuration shares (the same work: the solve's work units are printed), pooled over
all runs, plus `none`'s gather_q. Printed twice: from each pass's median over the frames (the
machine's load included) and from its fastest frame (the least disturbed). Raw samples go to
OUT/samples.json.

Usage: python3 benches/ss_cost.py [--bin target/release/translucent] [--base-bin OLD_BINARY]
       [--runs 5] [--frames 4] [--configs all,no_ss,none] [--out target/ss-cost]
       [-- extra render args, e.g. --width 256 --height 256, or --supersample 1]
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


# The passes whose work the terms change: the march, its depth pre-pass and the gather (the
# beam and second-collision sources, the upstream beam, the continuation). Every other pass does
# the same work in every configuration (the same solve: the work units are printed).
TERM_PASSES = ("single_scattering", "single_scattering_depths", "gather_q")


def run(binary, extra, out_dir, name, frames):
    """The frames after the first (which JIT-compiles pipelines Mesa's cache lacks), each a
    full cold frame (`--no-skip`): per frame, GPU ms per top-level pass."""
    out = os.path.join(out_dir, f"{name}.png")
    cmd = ["nice", "-n", "10", binary, "render", "--out", out, "--json",
           "--frames", str(frames + 1), "--no-skip", *extra]
    result = subprocess.run(cmd, capture_output=True, text=True, check=True)
    report = json.loads(result.stdout)["frames"]
    passes = [{k: v for k, v in f["passes"].items() if " " not in k} for f in report[1:]]
    return passes, report[-1].get("multigrid", {}).get("work_units")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bin", default="target/release/translucent")
    parser.add_argument("--base-bin", help="a second binary (before a change): adds 'all@base'")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--frames", type=int, default=4, help="timed frames per run")
    parser.add_argument("--out", default="target/ss-cost")
    parser.add_argument("--configs", default="all,no_ss,none")
    parser.add_argument("extra", nargs="*")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    names = args.configs.split(",")
    runs = {n: (args.bin, CONFIGS[n]) for n in names}
    if args.base_bin:
        names.insert(0, "all@base")
        runs["all@base"] = (args.base_bin, CONFIGS["all"])
    samples = {n: [] for n in names}
    loads = []
    work = {}
    for r in range(args.runs):
        for n in names:
            binary, config = runs[n]
            loads.append(load())
            passes, wu = run(binary, config + args.extra, args.out, n.replace("@", "_"),
                             args.frames)
            samples[n].extend(passes)
            work[n] = wu
            sums = " ".join(f"{sum(p.values()):.0f}" for p in passes)
            print(f"run {r} {n}: frames {sums} ms (load {loads[-1]:.1f})", file=sys.stderr)
    with open(os.path.join(args.out, "samples.json"), "w") as f:
        json.dump({"extra": args.extra, "loads": loads, "samples": samples}, f)
    report(names, samples, loads, work, args)


def report(names, samples, loads, work, args):
    """Medians per pass (the load's interference included) and the fastest frame of each pass
    (the least disturbed: interference only adds time), and the share the terms add by each."""
    for label, stat in (("medians", statistics.median), ("fastest", min)):
        table(names, samples, loads, work, args, label, stat)


def table(names, samples, loads, work, args, label, stat):
    med = {n: {p: stat([s.get(p, 0.0) for s in samples[n]])
               for p in {q for s in samples[n] for q in s}} for n in names}
    pass_names = sorted({p for n in names for p in med[n]})
    print(f"render args: {' '.join(args.extra) or '(defaults)'}; {args.runs} interleaved runs "
          f"x {args.frames} frames (+1 discarded each, `--no-skip`); load {min(loads):.1f}-{max(loads):.1f} "
          f"(median {statistics.median(loads):.1f}); GPU ms, {label} per pass")
    print("| pass | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for p in pass_names:
        print(f"| {p} | " + " | ".join(f"{med[n].get(p, 0.0):.1f}" for n in names) + " |")
    totals = {n: stat([sum(s.values()) for s in samples[n]]) for n in names}
    print(f"| frame ({label} of sums) | " + " | ".join(f"{totals[n]:.1f}" for n in names) + " |")
    print("| solve work units | " + " | ".join(f"{work[n]:.2f}" for n in names) + " |")
    if "none" not in names:
        return
    # The passes common to every configuration do the same work: their median over all runs of
    # every configuration is the least noisy estimate of the frame without the terms.
    common = sorted(p for p in pass_names if p not in TERM_PASSES)
    pooled = sum(stat([s.get(p, 0.0) for n in names for s in samples[n]]) for p in common)
    base = pooled + med["none"].get("gather_q", 0.0)
    print(f"frame without the terms (pooled common passes + gather_q of 'none'): {base:.1f} ms")
    for n in names:
        if n == "none":
            continue
        terms = sum(med[n].get(p, 0.0) for p in TERM_PASSES) - med["none"].get("gather_q", 0.0)
        print(f"{n}: the terms add {terms:.1f} ms = {100 * terms / base:.1f}% of the frame "
              f"without them ({100 * terms / (base + terms):.1f}% of the frame with them); "
              f"{label} of sums {totals[n]:.1f} vs {totals['none']:.1f} "
              f"({100 * (totals[n] / totals['none'] - 1):+.1f}%)")


if __name__ == "__main__":
    main()
