#!/usr/bin/env python3
"""One line of benches/gpu_terms.sh: terms_row.py SCENE VARIANT PREFIX SECONDS.

Reads PREFIX.compare.json (tools/compare_exr.py --json), PREFIX.json (render --json --profile)
and PREFIX.trace.json (render --trace: every frame's GPU scopes) and prints the relative RMS in %,
the frame's GPU ms (median over the frames in the trace), the passes the terms add (median ms),
the skipped passes and the wall seconds.
"""
import json
import statistics
import sys
from collections import defaultdict

scene, variant, prefix, seconds = sys.argv[1:5]
cmp = json.load(open(prefix + ".compare.json"))
run = json.load(open(prefix + ".json"))
trace = json.load(open(prefix + ".trace.json"))["traceEvents"]
# Per frame: top-level total and per-pass sums (a pass may run more than once per frame).
per_frame = defaultdict(lambda: defaultdict(float))
for e in trace:
    f = e["args"]["frame"]
    if e["args"]["depth"] == 0:
        per_frame[f]["total"] += e["dur"] / 1000.0
    per_frame[f][e["name"]] += e["dur"] / 1000.0
frames = sorted(per_frame)


def median(name):
    return statistics.median(per_frame[f].get(name, 0.0) for f in frames)


terms = {
    "ss": median("single_scattering") + median("single_scattering_depths"),
    "gather_q": median("gather_q"),
    "diffusion": median("diffusion"),
    "exitance": median("exitance"),
}
skipped = sorted({k for fr in run["frames"] for k in fr.get("skipped", {})})
rel = " ".join(f"{100 * v:.1f}," if v is not None else "-," for v in cmp["rel_rms"]).rstrip(",")
print(
    f"{scene} {variant}: {rel} ({100 * cmp['rel_rms_all']:.1f}) | ratio of means "
    + ", ".join(f"{r:.3f}" for r in cmp["ratio_of_means"])
    + f" | GPU ms (median of {len(frames)} frames) total {median('total'):.1f}, "
    + ", ".join(f"{k} {v:.1f}" for k, v in terms.items())
    + f" | skipped {','.join(skipped) or '-'} | {seconds} s"
)
