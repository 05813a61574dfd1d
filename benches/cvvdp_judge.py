#!/usr/bin/env python3
"""ColorVideoVDP (Mantiuk et al. 2024) as the judge of `aleph speedup`'s renders.

Reads the display images `aleph speedup` writes into its output directory and scores each sampler
at each budget against the reference with ColorVideoVDP, in JOD (10 = indistinguishable from the
reference):

- a sequence (`DIR/frames/ARM-Bspp/NNNN.png`, `DIR/frames/reference/NNNN.png`): one video score
  per sampler and budget, the frames played at `--fps` (ColorVideoVDP models temporal vision, so
  it can credit noise that moving content hides, which FLIP cannot);
- a still (`DIR/ARM-Bspp.png` against `DIR/reference.png`): one image score each.

With `aleph speedup --stop`, the perceptual sampler's own stop (`DIR/perceptual-stop.png`, or
`DIR/frames/perceptual-stop/`) is scored too, with the uniform spp and wall time that reach its
JOD.

Then, for each uniform budget's JOD, the samples each other sampler needs for that JOD (log-log
interpolation of spp against 10 − JOD, as `aleph speedup` does for FLIP), and the speedups.
Writes `DIR/cvvdp.md` and `DIR/cvvdp.csv`.

Display model: ColorVideoVDP's `standard_4k` (30-inch 4K SDR monitor, 200 cd/m² peak, 250 lux,
0.75 m: about 75 pixels per degree, close to the 67 ppd aleph's judges assume). The PNGs are
sRGB display values, as a viewer sees them.

The same renders graded 2 stops darker and brighter (the ends of the exposure latitude) are in
`DIR/ev-2` and `DIR/ev+2`: pass either as DIR to judge that grade.

Install (CPU PyTorch comes with it; about 3 GB):
    python3 -m venv benches/.venv && benches/.venv/bin/pip install cvvdp
Run:
    benches/.venv/bin/python benches/cvvdp_judge.py speedup-cornell-motion --fps 24
"""

import argparse
import csv
import math
import os
import re
import sys

import numpy as np
from PIL import Image


def load_stack(paths):
    return np.stack([np.asarray(Image.open(p).convert("RGB")) for p in paths])


def arms_in(frames_dir):
    """{(arm, budget): sorted frame paths} from DIR/frames/ARM-Bspp/NNNN.png."""
    out = {}
    for name in sorted(os.listdir(frames_dir)):
        m = re.fullmatch(r"(.+)-([0-9.]+)spp", name)
        if not m:
            continue
        d = os.path.join(frames_dir, name)
        out[(m.group(1), float(m.group(2)))] = sorted(
            os.path.join(d, f) for f in os.listdir(d) if f.endswith(".png")
        )
    return out


def spp_used(directory, table="speedup.csv"):
    """(arm, budget) -> (mean spp actually used, wall s), from `table` (speedup.csv)."""
    used = {}
    path = os.path.join(directory, table)
    if not os.path.exists(path):
        # A graded subdirectory (DIR/ev-2, DIR/ev+2) shares its parent's table.
        path = os.path.join(directory, os.pardir, table)
    if not os.path.exists(path):
        return used
    with open(path) as f:
        for row in csv.DictReader(f):
            used[(row["sampler"], float(row["budget_spp"]))] = (
                float(row["mean_spp"]),
                float(row["wall_s"]),
            )
    return used


def samples_for(curve, target):
    """Log-log interpolation of x where 10 − JOD(x) reaches 10 − target; curve: [(x, jod)]."""
    pts = sorted(curve)
    err = lambda j: max(10.0 - j, 1e-6)
    for (x0, j0), (x1, j1) in zip(pts, pts[1:]):
        e0, e1, et = err(j0), err(j1), err(target)
        if (e0 - et) * (e1 - et) <= 0 and e0 != e1:
            t = (math.log(et) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(x0) + t * (math.log(x1) - math.log(x0)))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", help="output directory of `aleph speedup`")
    ap.add_argument("--fps", type=float, default=24.0, help="frame rate of a sequence")
    ap.add_argument("--display", default="standard_4k", help="ColorVideoVDP display model")
    args = ap.parse_args()

    import pycvvdp  # after argument parsing: `--help` works without the package

    import torch

    metric = pycvvdp.cvvdp(display_name=args.display, quiet=True, device=torch.device("cpu"))
    frames_dir = os.path.join(args.dir, "frames")
    sequence = os.path.isdir(frames_dir)
    if sequence:
        renders = arms_in(frames_dir)
        ref_paths = sorted(
            os.path.join(frames_dir, "reference", f)
            for f in os.listdir(os.path.join(frames_dir, "reference"))
        )
        reference = load_stack(ref_paths)
    else:
        renders = {}
        for f in sorted(os.listdir(args.dir)):
            m = re.fullmatch(r"(.+)-([0-9.]+)spp\.png", f)
            if m:
                renders[(m.group(1), float(m.group(2)))] = [os.path.join(args.dir, f)]
        reference = load_stack([os.path.join(args.dir, "reference.png")])

    used = spp_used(args.dir)
    stop_paths = []
    if sequence and os.path.isdir(os.path.join(frames_dir, "perceptual-stop")):
        d = os.path.join(frames_dir, "perceptual-stop")
        stop_paths = sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".png"))
    elif os.path.exists(os.path.join(args.dir, "perceptual-stop.png")):
        stop_paths = [os.path.join(args.dir, "perceptual-stop.png")]
    jod = {}
    for key, paths in sorted(renders.items()):
        test = load_stack(paths)
        if test.shape != reference.shape:
            sys.exit(f"{key}: {test.shape} frames differ from the reference's {reference.shape}")
        if sequence:
            q, _ = metric.predict(test, reference, dim_order="FHWC", frames_per_second=args.fps)
        else:
            q, _ = metric.predict(test[0], reference[0], dim_order="HWC")
        jod[key] = float(q)
        print(f"{key[0]:>22} {key[1]:>6g} spp: JOD {jod[key]:.3f}", flush=True)

    arms = sorted({a for a, _ in jod})
    with open(os.path.join(args.dir, "cvvdp.csv"), "w") as f:
        f.write("sampler,budget_spp,mean_spp,wall_s,jod\n")
        for (a, b), q in sorted(jod.items()):
            spp, wall = used.get((a, b), (float("nan"), float("nan")))
            f.write(f"{a},{b},{spp:.4f},{wall:.4f},{q:.4f}\n")

    def curve(arm, axis):
        return [
            (used[(a, b)][axis], q) for (a, b), q in jod.items() if a == arm and (a, b) in used
        ]

    lines = [
        f"# ColorVideoVDP: {args.dir}",
        "",
        f"Display model `{args.display}`; "
        + (f"video at {args.fps:g} fps." if sequence else "still image."),
        "",
        "| uniform spp | JOD | " + " | ".join(f"{a} spp | speedup (spp) | speedup (time)" for a in arms if a != "uniform") + " |",
        "|---|---|" + "---|---|---|" * (len(arms) - 1),
    ]
    uni = sorted(curve("uniform", 0))
    uni_t = curve("uniform", 1)
    for x, q in uni[1:]:
        row = f"| {x:.1f} | {q:.3f} |"
        for a in arms:
            if a == "uniform":
                continue
            s, t = samples_for(curve(a, 0), q), samples_for(curve(a, 1), q)
            ut = samples_for(uni_t, q)
            row += f" {s:.1f} | {x / s:.2f}× |" if s else " — | — |"
            row += f" {ut / t:.2f}× |" if (t and ut) else " — |"
        lines.append(row)
    if stop_paths:
        test = load_stack(stop_paths)
        if sequence:
            q, _ = metric.predict(test, reference, dim_order="FHWC", frames_per_second=args.fps)
        else:
            q, _ = metric.predict(test[0], reference[0], dim_order="HWC")
        q = float(q)
        spp, wall = spp_used(args.dir, "stop.csv").get(("perceptual", 0.0), (None, None))
        us, ut = samples_for(uni, q), samples_for(uni_t, q)
        fmt = lambda v, p: f"{v:.{p}f}" if v is not None else "—"
        lines += [
            "",
            "## The default stop",
            "",
            f"The perceptual sampler's own stop: JOD {q:.3f} at {fmt(spp, 1)} spp in {fmt(wall, 2)} s. "
            f"Uniform reaches that JOD at {fmt(us, 0)} spp in {fmt(ut, 2)} s"
            + (f": the stop takes {spp / us:.2f}× its samples and {wall / ut:.2f}× its time."
               if None not in (spp, us, wall, ut) else " (outside the sweep's budgets: —)."),
        ]
        print(f"{'perceptual-stop':>22}: JOD {q:.3f}", flush=True)
    with open(os.path.join(args.dir, "cvvdp.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
