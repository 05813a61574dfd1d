#!/usr/bin/env python3
"""Judges aleph's denoised renders (issue 37) with metrics aleph did not write.

Renders a scene with the aleph CLI (a `--features denoise` build) in these arms, each in a
process of its own, timed from start to exit (load, auxiliary images and denoising included):

- `uniform`: uniform sampling, no denoising, at 1-1024 spp (the baseline curve);
- `uniform+oidn`: uniform sampling denoised by Open Image Denoise, at 1-64 spp;
- `perceptual+oidn`: the perceptual sampler with the denoiser in its loop
  (`--denoise --steer-from 0`), under budgets of 4-64 spp;
- `stop+oidn` and `stop`: the perceptual sampler's own stop (no budget) with and without
  `--denoise` (with it the first pass is 32 spp: `aleph::job::DENOISED_STOP_MIN_SPP`).

Each PNG (the image as displayed, aleph's default tone curve) is scored against a uniform
reference of `--reference-spp` samples per pixel by FLIP (flip-evaluator, LDR, 67 ppd; mean and
99th percentile of the error map) and ColorVideoVDP (`standard_4k`, JOD, 10 = no visible
difference). For each score the samples and the wall time uniform sampling needs to reach it
(log-log interpolation along the uniform curve) give the speedups. Each `--grades` EV other
than 0 judges every arm's EXR and the reference graded that many stops under the reference's
frozen curve (`aleph tonemap --operator reinhard --curve-from reference.exr --grade EV`, as a
user who grades the EXR darker or brighter sees it; `aleph speedup` grades the same way).
With `--seeds N` every arm but the references is rendered under seeds 0..N-1 (seed 0 keeps the
plain stem, seed k the suffix `-sK`) and each row is the mean of its N renders' scores, spp and
wall times: a denoised image's scores scatter from seed to seed by more than the uniform+oidn
curve moves between budgets (docs/denoise.md, "How much of that is one seed"). The floor's
reference keeps seed 2 at `--reference-spp`. `--denoise-quality fast` gives every denoised arm
`aleph render --denoise-quality fast` (OIDN's fast model for the result). Writes DIR/denoise.csv (one row per render) and
DIR/denoise.md (a table per grade, of the means).

Install (CPU PyTorch comes with cvvdp; about 3 GB):
    python3 -m venv benches/.venv && benches/.venv/bin/pip install cvvdp flip-evaluator
Build and run:
    eval "$(bash scripts/oidn.sh)" && cargo build --release --features denoise
    benches/.venv/bin/python benches/denoise_judge.py scenes/cornell-box/scene.toml \\
        --resolution 256x256 --out denoise-cornell-box
"""

import argparse
import csv
import math
import os
import re
import subprocess
import sys
import time

import numpy as np
from PIL import Image

UNIFORM = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
DENOISED = [1, 2, 4, 8, 16, 32, 64]
PERCEPTUAL = [4, 8, 16, 32, 64]
SPP_RE = re.compile(r"([0-9.]+) spp mean")


def render(aleph, scene, resolution, stem, args):
    """Runs aleph; returns (mean spp, wall seconds)."""
    cmd = [aleph, "render", scene, "--resolution", resolution, "-o", stem, *args]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {out.returncode}\n{out.stderr}")
    spp = float(SPP_RE.search(out.stdout + out.stderr).group(1))
    return spp, wall


def load(path):
    return np.asarray(Image.open(path).convert("RGB"))


def load_runs(cache):
    """{stem: (spp, wall seconds)} of the renders cached in `cache` (runs.csv), if it exists."""
    measured = {}
    if os.path.exists(cache):
        with open(cache) as f:
            for r in csv.DictReader(f):
                measured[r["stem"]] = (float(r["spp"]), float(r["wall_s"]))
    return measured


def interpolate(curve, target, better_low):
    """The x (spp or seconds) at which the uniform `curve` [(x, score)] reaches `target`:
    log-log interpolation of x against the score (FLIP) or against 10 - JOD."""
    f = (lambda s: math.log(max(s, 1e-9))) if better_low else (lambda s: math.log(max(10 - s, 1e-9)))
    pts = sorted(curve)
    for (x0, s0), (x1, s1) in zip(pts, pts[1:]):
        a, b, t = f(s0), f(s1), f(target)
        if (a - t) * (b - t) <= 0 and a != b:
            u = (t - a) / (b - a)
            return math.exp(math.log(x0) + u * (math.log(x1) - math.log(x0)))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--resolution", default="256x256")
    ap.add_argument("--out", required=True, help="output directory (renders are kept and reused)")
    ap.add_argument("--aleph", default="target/release/aleph")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--grades", default="0,-2,2",
                    help="EV grades to judge at (0: as displayed; others under the reference's frozen curve)")
    ap.add_argument("--seeds", type=int, default=1,
                    help="render every arm but the references under seeds 0..N-1 and judge the means")
    ap.add_argument("--denoise-quality", choices=["high", "fast"], default="high",
                    help="the denoised arms' final model (aleph render --denoise-quality); "
                         "use another --out per model, the renders are cached by name")
    args = ap.parse_args()
    if args.seeds < 1:
        sys.exit("--seeds must be at least 1")
    args.grades = [float(g) for g in args.grades.split(",")]
    os.makedirs(args.out, exist_ok=True)

    dq = ["--denoise-quality", args.denoise_quality]
    runs = []  # (arm, budget, stem, args)
    runs.append(("reference", args.reference_spp, "reference", ["--sampler", "uniform", "--spp", str(args.reference_spp)]))
    for n in UNIFORM:
        runs.append(("uniform", n, f"uniform-{n}", ["--sampler", "uniform", "--spp", str(n)]))
    for n in DENOISED:
        runs.append(("uniform+oidn", n, f"uniform-oidn-{n}", ["--sampler", "uniform", "--spp", str(n), "--denoise", *dq]))
    for n in PERCEPTUAL:
        runs.append(("perceptual+oidn", n, f"perceptual-oidn-{n}",
                     ["--spp", str(n), "--denoise", *dq, "--steer-from", "0", "--min-spp", "2"]))
    runs.append(("stop+oidn", 0, "stop-oidn", ["--denoise", *dq]))
    runs.append(("stop", 0, "stop", []))
    seeded = runs[:1]
    for arm, budget, stem, extra in runs[1:]:
        seeded.append((arm, budget, stem, extra))
        for k in range(1, args.seeds):
            seeded.append((arm, budget, f"{stem}-s{k}", [*extra, "--seed", str(k)]))
    runs = seeded
    # A second reference of another seed: its scores against the first are the judges' floor
    # (the reference's own noise), which the honest stop is held to.
    runs.append(("floor", args.reference_spp, "reference-seed2",
                 ["--sampler", "uniform", "--spp", str(args.reference_spp), "--seed", "2"]))

    cache = os.path.join(args.out, "runs.csv")
    measured = load_runs(cache)
    for arm, budget, stem, extra in runs:
        if stem in measured and os.path.exists(os.path.join(args.out, stem + ".png")):
            continue
        measured[stem] = render(args.aleph, args.scene, args.resolution, os.path.join(args.out, stem), extra)
        print(f"{stem}: {measured[stem][0]:.1f} spp, {measured[stem][1]:.2f} s", flush=True)
        with open(cache, "w") as f:
            f.write("stem,spp,wall_s\n")
            for s, (spp, wall) in measured.items():
                f.write(f"{s},{spp},{wall}\n")

    import flip_evaluator as flip
    import pycvvdp
    import torch

    metric = pycvvdp.cvvdp(display_name="standard_4k", quiet=True, device=torch.device("cpu"))
    rows = []
    for grade in args.grades:
        ref = load(display(args, "reference", grade))
        for arm, budget, stem, _ in runs[1:]:
            test = load(display(args, stem, grade))
            fmap, fmean, _ = flip.evaluate(ref.astype(np.float32) / 255, test.astype(np.float32) / 255,
                                           "LDR", applyMagma=False, parameters={"ppd": 67.0})
            p99 = float(np.percentile(fmap, 99))
            jod = float(metric.predict(test, ref, dim_order="HWC")[0])
            spp, wall = measured[stem]
            rows.append(dict(grade=grade, arm=arm, budget=budget, stem=stem, spp=spp, wall=wall,
                             flip=float(fmean), p99=p99, jod=jod))
            print(f"{grade:+.0f} EV {stem:>22}: {spp:7.1f} spp {wall:6.2f} s  FLIP {fmean:.4f}  p99 {p99:.4f}  "
                  f"JOD {jod:.3f}", flush=True)

    with open(os.path.join(args.out, "denoise.csv"), "w") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    lines = [
        f"# Denoising judged by FLIP and ColorVideoVDP: {args.scene} at {args.resolution}",
        "",
        f"Reference: uniform {args.reference_spp} spp. Each arm in a process of its own, wall time from start to exit.",
        "Speedup: the uniform samples (time) that reach the same score, over the arm's; the last",
        "two columns against uniform+oidn (the same denoiser) instead of uniform.",
    ]
    if args.seeds > 1:
        lines.append(f"Each row: the mean of {args.seeds} renders, seeds 0-{args.seeds - 1}.")
    for grade in args.grades:
        lines += table(mean_rows([r for r in rows if r["grade"] == grade]), grade)
    with open(os.path.join(args.out, "denoise.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def display(args, stem, grade):
    """The display PNG of render `stem` at `grade` stops: the render's own PNG at 0, else its EXR
    graded under the reference's frozen curve by `aleph tonemap` (made once, then reused)."""
    if grade == 0:
        return os.path.join(args.out, stem + ".png")
    out = os.path.join(args.out, f"{stem}.ev{grade:+.0f}.png")
    if not os.path.exists(out):
        cmd = [args.aleph, "tonemap", os.path.join(args.out, stem + ".exr"), out, "--operator", "reinhard",
               "--curve-from", os.path.join(args.out, "reference.exr"), "--grade", str(grade)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr}")
    return out


def mean_rows(rows):
    """`rows` with the renders of one arm and budget (its seeds) merged into their mean, in
    order of first appearance."""
    groups = {}
    for r in rows:
        groups.setdefault((r["arm"], r["budget"]), []).append(r)
    merged = []
    for (arm, budget), rs in groups.items():
        m = dict(rs[0], arm=arm, budget=budget)
        for key in ("spp", "wall", "flip", "p99", "jod"):
            m[key] = sum(r[key] for r in rs) / len(rs)
        merged.append(m)
    return merged


def table(rows, grade):
    """The markdown table of one grade's `rows`."""
    uni = [r for r in rows if r["arm"] == "uniform"]
    den = [r for r in rows if r["arm"] == "uniform+oidn"]
    floor = next(r for r in rows if r["arm"] == "floor")
    lines = [
        "",
        "As displayed:" if grade == 0 else f"Graded {grade:+.0f} EV under the reference's curve:",
        "",
        f"Floor (a second reference, seed 2): FLIP mean {floor['flip']:.4f}, p99 {floor['p99']:.4f}, "
        f"JOD {floor['jod']:.3f}.",
        "",
        "| arm | budget | spp | wall s | FLIP mean | FLIP p99 | JOD | × spp (FLIP mean) | × spp (p99) | × spp (JOD) "
        "| × time (FLIP mean) | × time (JOD) | × spp vs +oidn (p99) | × spp vs +oidn (JOD) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["arm"] == "floor":
            continue

        def ratio(key, low, axis, curve=uni):
            x = interpolate([(u[axis], u[key]) for u in curve], r[key], low)
            return f"{x / r[axis]:.2f}×" if x else "—"

        vs_oidn = ("—", "—")
        if r["arm"].startswith(("perceptual+oidn", "stop+oidn")):
            vs_oidn = (ratio("p99", True, "spp", den), ratio("jod", False, "spp", den))
        lines.append(
            f"| {r['arm']} | {r['budget'] or 'stop'} | {r['spp']:.1f} | {r['wall']:.2f} | {r['flip']:.4f} | "
            f"{r['p99']:.4f} | {r['jod']:.3f} | {ratio('flip', True, 'spp')} | {ratio('p99', True, 'spp')} | "
            f"{ratio('jod', False, 'spp')} | {ratio('flip', True, 'wall')} | {ratio('jod', False, 'wall')} | "
            f"{vs_oidn[0]} | {vs_oidn[1]} |"
        )
    return lines


if __name__ == "__main__":
    main()
