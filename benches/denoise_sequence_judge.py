#!/usr/bin/env python3
"""Denoising a sequence, with and without reuse across frames, judged as video (issue 37).

Renders one animated scene's frames with `aleph render --frames` in five arms and judges each as
a video with ColorVideoVDP (`standard_4k`, the scene's fps), which sees flicker, and per frame
with FLIP (mean over frames):

- `uniform`: independent frames, uniform sampling, 1-64 spp;
- `uniform+oidn`: the same, each frame denoised by Open Image Denoise (`--denoise`);
- `reuse`: the default sampler of a sequence, reusing the K frames before each frame
  (`--reuse-window`, default 15), at 1-16 fresh spp;
- `reuse+oidn`: the same, each frame denoised after reuse;
- the reference: uniform at `--reference-spp`, and a second reference of another seed whose
  scores against the first are the judges' floor.

Every arm's PNGs are tone-mapped alike: the operator's adaptation comes from a pre-pass that
does not depend on the sampler. Each arm renders the warm-up frames it needs before the first
judged frame (`--frames A-B` does that by itself). Wall time is the whole process, warm-up
included. For each arm and budget the table gives the uniform spp with the same video JOD /
FLIP mean (log-log interpolation) and the ratio of samples, and the same in wall time.

Install (once; the denoiser build needs OIDN from scripts/oidn.sh):
    python3 -m venv benches/.venv && benches/.venv/bin/pip install cvvdp flip-evaluator
    eval "$(bash scripts/oidn.sh)" && cargo build --release --features denoise
Run:
    benches/.venv/bin/python benches/denoise_sequence_judge.py scenes/holodeck/pan.toml \\
        --frames 12-19 --resolution 240x160 --out denoise-pan
"""

import argparse
import csv
import os
import re
import subprocess
import sys
import time

import numpy as np
from PIL import Image

from denoise_judge import interpolate, load_runs  # shared with the stills' judge

UNIFORM = [1, 2, 4, 8, 16, 32, 64]
DENOISED = [1, 2, 4, 8, 16]
REUSE = [1, 2, 4, 8, 16]
SPP_RE = re.compile(r"sequence of .*?, ([0-9.]+) spp mean")


def render(aleph, scene, frames, resolution, stem, args):
    """Runs aleph on the frames; returns (mean fresh spp, wall seconds)."""
    cmd = [aleph, "render", scene, "--frames", frames, "--resolution", resolution, "-o", stem, *args]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {out.returncode}\n{out.stderr}")
    m = SPP_RE.search(out.stdout + out.stderr)
    return (float(m.group(1)) if m else float("nan")), wall


def frame_paths(stem, frames):
    a, b = (int(x) for x in frames.split("-"))
    return [f"{stem}.{i:04d}.png" for i in range(a, b + 1)]


def load_stack(paths):
    return np.stack([np.asarray(Image.open(p).convert("RGB")) for p in paths])


def runs_of(reference_spp):
    runs = [("reference", reference_spp, "reference", ["--sampler", "uniform", "--spp", str(reference_spp)])]
    runs += [("uniform", n, f"uniform-{n}", ["--sampler", "uniform", "--spp", str(n)]) for n in UNIFORM]
    runs += [("uniform+oidn", n, f"uniform-oidn-{n}", ["--sampler", "uniform", "--spp", str(n), "--denoise"])
             for n in DENOISED]
    runs += [("reuse", n, f"reuse-{n}", ["--spp", str(n)]) for n in REUSE]
    runs += [("reuse+oidn", n, f"reuse-oidn-{n}", ["--spp", str(n), "--denoise"]) for n in REUSE]
    runs.append(("floor", reference_spp, "reference-seed2",
                 ["--sampler", "uniform", "--spp", str(reference_spp), "--seed", "2"]))
    return runs


def render_all(args, runs):
    """Renders what is not cached in OUT/runs.csv; returns {stem: (spp, wall)}."""
    cache = os.path.join(args.out, "runs.csv")
    measured = load_runs(cache)
    for arm, budget, stem, extra in runs:
        path = os.path.join(args.out, stem)
        if stem in measured and all(os.path.exists(p) for p in frame_paths(path, args.frames)):
            continue
        measured[stem] = render(args.aleph, args.scene, args.frames, args.resolution, path, extra)
        print(f"{stem}: {measured[stem][0]:.2f} spp, {measured[stem][1]:.2f} s", flush=True)
        with open(cache, "w") as f:
            f.write("stem,spp,wall_s\n")
            for s, (spp, wall) in measured.items():
                f.write(f"{s},{spp},{wall}\n")
    return measured


def judge(args, runs, measured):
    import flip_evaluator as flip
    import pycvvdp
    import torch

    metric = pycvvdp.cvvdp(display_name="standard_4k", quiet=True, device=torch.device("cpu"))
    ref = load_stack(frame_paths(os.path.join(args.out, "reference"), args.frames))
    rows = []
    for arm, budget, stem, _ in runs[1:]:
        test = load_stack(frame_paths(os.path.join(args.out, stem), args.frames))
        flips = []
        for t, r in zip(test, ref):
            _, fmean, _ = flip.evaluate(r.astype(np.float32) / 255, t.astype(np.float32) / 255,
                                        "LDR", applyMagma=False, parameters={"ppd": 67.0})
            flips.append(float(fmean))
        jod = float(metric.predict(test, ref, dim_order="FHWC", frames_per_second=args.fps)[0])
        spp, wall = measured[stem]
        rows.append(dict(arm=arm, budget=budget, spp=spp, wall=wall, flip=float(np.mean(flips)),
                         flip_worst=float(np.max(flips)), jod=jod))
        print(f"{stem:>18}: {spp:6.2f} spp {wall:7.2f} s  FLIP {np.mean(flips):.4f} "
              f"(worst frame {np.max(flips):.4f})  JOD {jod:.3f}", flush=True)
    return rows


def table(rows):
    uni = [r for r in rows if r["arm"] == "uniform"]

    def ratio(r, key, better_low, x):
        curve = [(u[x], u[key]) for u in uni]
        at = interpolate(curve, r[key], better_low)
        return "—" if at is None else f"{at / r[x]:.2f}×"

    lines = [
        "| arm | budget | spp | wall s | FLIP mean | worst frame | video JOD | × spp (FLIP) "
        "| × spp (JOD) | × time (FLIP) | × time (JOD) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['arm']} | {r['budget']} | {r['spp']:.2f} | {r['wall']:.2f} | {r['flip']:.4f} | "
            f"{r['flip_worst']:.4f} | {r['jod']:.3f} | {ratio(r, 'flip', True, 'spp')} | "
            f"{ratio(r, 'jod', False, 'spp')} | {ratio(r, 'flip', True, 'wall')} | "
            f"{ratio(r, 'jod', False, 'wall')} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--frames", required=True, help="A-B, the judged frames")
    ap.add_argument("--resolution", default="240x160")
    ap.add_argument("--fps", type=float, default=24.0)
    ap.add_argument("--out", required=True, help="output directory (renders are kept and reused)")
    ap.add_argument("--aleph", default="target/release/aleph", help="a build with --features denoise")
    ap.add_argument("--reference-spp", type=int, default=1024)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    runs = runs_of(args.reference_spp)
    measured = render_all(args, runs)
    rows = judge(args, runs, measured)
    with open(os.path.join(args.out, "denoise-sequence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    md = table(rows)
    with open(os.path.join(args.out, "denoise-sequence.md"), "w") as f:
        f.write(md + "\n")
    print(md)


if __name__ == "__main__":
    main()
