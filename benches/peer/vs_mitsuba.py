#!/usr/bin/env python3
"""aleph against Mitsuba 3 in time to equal error, measured in one run.

Setup (once; nothing here is needed by the tests or CI): ``bash benches/peer/setup.sh``
creates ``benches/peer/.venv`` with mitsuba, numpy and flip-evaluator, and installs Debian's
``libllvm19`` (as root) for Mitsuba's vectorised ``llvm_ad_rgb`` variant. Then::

    benches/peer/.venv/bin/python benches/peer/vs_mitsuba.py [--variant llvm_ad_rgb]
        [--sampler multijitter] [--res 256] [--spp 16 64] [--rounds 5] [--max-depth 8]
        [--ref-spp 8192] [--scenes cornell lost-empire lost-empire-interior]

Mitsuba runs with the sampler its users would pick (``--sampler``, default ``multijitter``:
measured on the Cornell box at 256², depth 8, 3 seeds, relMSE at 16 / 64 spp ``independent``
0.01098 / 0.00279, ``stratified`` 0.00742 / 0.00155, ``ldsampler`` 0.00712 / 0.00138,
``multijitter`` 0.00657 / 0.00130), and each renderer is timed in a process of its own: every
timed Mitsuba render is a child process of this script (import, scene load, a 4-spp warm-up
that compiles the kernel, then the timed render), so no Dr.Jit thread exists while aleph
renders, and aleph runs as its own process while this script waits.

Three scenes (``--scenes``): the bundled Cornell box (McGuire's OBJ, the same camera, lights,
depth and box filter in both renderers), scored against one common Mitsuba reference
(``--ref-spp``, cached in ``target/peer/``); and the bundled Lost Empire (225k triangles, its
texture atlas on one Lambertian material under a constant sky and a sun, as
``textured_scene.py`` writes it for both), 320×200, where each renderer is scored against its
own ``--textured-ref-spp`` reference (their means agree to 5 digits, but texture filtering
need not agree texel by texel); and an interior of the same Lost Empire scene (a roofed hall
lit through its openings, where most light arrives after several bounces), 320×200, scored
against one common reference, the mean of both renderers' ``--interior-ref-spp`` renders, and
scored at the exposure that takes that reference's mean luminance to 0.18 (at exposure 0 the
hall's mean is 0.004, and relMSE's 0.01 in the denominator would make it an absolute MSE). For each scene and budget it alternates aleph (``render --sampler uniform``, the
render time from its own summary) and Mitsuba (``mi.render`` timed in its child process after
the warm-up, so the LLVM kernel compile is not counted) for ``--rounds`` rounds. Each image is scored against the
reference by relMSE (mean of (x − r)² / (r² + 0.01), per channel) and FLIP (mean, 67 ppd,
via ``flip-evaluator`` on the sRGB images at exposure 0; the interior at its own, above). For Monte Carlo noise relMSE falls as
1/time, so each renderer's efficiency is 1 / (relMSE × time), and FLIP (an amplitude) as
1/sqrt(time), giving 1 / (FLIP² × time); the ratio aleph/Mitsuba > 1 means aleph reaches equal
error sooner. Prints the CPU (Mitsuba's LLVM variant vectorises to its widest SIMD, so the ratios
depend on it), a table, and writes ``target/peer/vs_mitsuba.csv``.
"""
import argparse, csv, json, os, re, subprocess, sys, tempfile, time

import numpy as np
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import machine  # noqa: E402 (beside this file)
OUT = os.path.join(ROOT, "target", "peer")
ALEPH = os.path.join(ROOT, "target", "release", "aleph")
SCENE = os.path.join(ROOT, "scenes", "cornell-box", "scene.toml")
SCENES = ["cornell", "lost-empire", "lost-empire-interior"]


def rel_mse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + 1e-2)))


def flip_mean(x, r):
    try:
        import flip_evaluator as flip
    except ImportError:
        return float("nan")
    srgb = lambda a: np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(np.clip(a, 0.0031308, None), 1 / 2.4) - 0.055)
    ref = np.clip(srgb(np.clip(r, 0, 1)), 0, 1).astype(np.float32)
    test = np.clip(srgb(np.clip(x, 0, 1)), 0, 1).astype(np.float32)
    _, mean, _ = flip.evaluate(ref, test, "LDR")
    return float(mean)


def read_exr_rgb(path):
    """R, G, B of an EXR's root layer (aleph's EXRs carry spp and other channels beside them)."""
    root = dict(mi.Bitmap(path).split())["<root>"]
    names = [root.struct_()[i].name for i in range(root.channel_count())]
    arr = np.array(root, dtype=np.float32).reshape(root.height(), root.width(), len(names))
    return arr[:, :, [names.index(c) for c in ("R", "G", "B")]]


def aleph_render(scene, spp, res, depth, seed, tmp):
    out = os.path.join(tmp, f"a{seed}")
    p = subprocess.run(
        [ALEPH, "render", scene, "--sampler", "uniform", "--spp", str(spp), "--resolution", f"{res[0]}x{res[1]}",
         "--max-depth", str(depth), "--seed", str(seed), "-o", out],
        capture_output=True, text=True, check=True)
    line = p.stdout + p.stderr
    m = re.search(r", ([0-9.]+) s \(first pass", line)
    secs = float(m.group(1))
    return read_exr_rgb(out + ".exr"), secs


def mitsuba_reference(scene, spp, path):
    """Mean of `spp` samples in chunks of at most 1024 (cached at `path`)."""
    if not os.path.exists(path):
        acc = None
        chunks = max(1, spp // 1024)
        for k in range(chunks):
            img = np.array(mi.render(scene, spp=spp // chunks, seed=10_000 + k))[:, :, :3]
            acc = img if acc is None else acc + img
            print(f"reference {k + 1}/{chunks}", file=sys.stderr)
        mi.Bitmap(np.ascontiguousarray(acc / chunks, dtype=np.float32)).write(path)
    return read_exr_rgb(path)


def mitsuba_scene(name, args, tmp, sampler="independent"):
    """Mitsuba's scene `name` with `sampler` (the references use ``independent``)."""
    import mitsuba_cornell as mc
    import textured_scene as ts
    # Mitsuba's path tracer counts depth as vertices from the camera (max_depth = bounces + 1).
    if name == "cornell":
        d = mc.aleph_box(args.res, args.max_depth + 1, tmp)
    else:
        view = "interior" if name == "lost-empire-interior" else "exterior"
        d = ts.mitsuba_dict(mi, (args.res * 5 // 4, args.res * 25 // 32), args.max_depth + 1, view)
    d["sensor"]["sampler"] = {"type": sampler}
    return mi.load_dict(d)


def mitsuba_child(spec):
    """Runs in a child process: one timed Mitsuba render (after a 4-spp warm-up that compiles
    the kernel), written as an EXR; prints the seconds."""
    a = argparse.Namespace(**spec["args"])
    mi.set_variant(a.variant)
    with tempfile.TemporaryDirectory() as tmp:
        scene = mitsuba_scene(spec["scene"], a, tmp, a.sampler)
        np.array(mi.render(scene, spp=4, seed=spec["seed"]))
        t0 = time.perf_counter()
        img = np.array(mi.render(scene, spp=spec["spp"], seed=spec["seed"]))[:, :, :3]
        secs = time.perf_counter() - t0
    mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32)).write(spec["out"])
    print(secs)


def mitsuba_render(name, args, spp, seed, tmp):
    """(image, seconds) of one Mitsuba render in a process of its own."""
    out = os.path.join(tmp, f"m{seed}.exr")
    spec = dict(scene=name, spp=spp, seed=seed, out=out, args=vars(args))
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(spec)],
                       capture_output=True, text=True, check=True)
    return read_exr_rgb(out), float(p.stdout.strip().splitlines()[-1])


def setup(name, args, tmp):
    """(aleph scene file, resolution, reference for aleph, reference for Mitsuba, the exposure
    both renderers' images are scored at) of benchmark scene `name`."""
    import textured_scene as ts
    scene = mitsuba_scene(name, args, tmp)
    if name == "cornell":
        res = (args.res, args.res)
        ref = mitsuba_reference(scene, args.ref_spp, os.path.join(OUT, f"ref-{args.res}-{args.max_depth}-{args.ref_spp}.exr"))
        return SCENE, res, ref, ref, 1.0
    view = "interior" if name == "lost-empire-interior" else "exterior"
    res = (args.res * 5 // 4, args.res * 25 // 32)
    ref_spp = args.interior_ref_spp if view == "interior" else args.textured_ref_spp
    toml = ts.aleph_toml(res, view=view)
    tag = f"{res[0]}x{res[1]}-{args.max_depth}-{ref_spp}"
    ref_m = mitsuba_reference(scene, ref_spp, os.path.join(OUT, f"ref-{name}-mitsuba-{tag}.exr"))
    ref_a_path = os.path.join(OUT, f"ref-{name}-aleph-{tag}.exr")
    if not os.path.exists(ref_a_path):
        img, _ = aleph_render(toml, ref_spp, res, args.max_depth, 10_000, tmp)
        mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32)).write(ref_a_path)
    ref_a = read_exr_rgb(ref_a_path)
    if view == "exterior":
        return toml, res, ref_a, ref_m, 1.0
    # The interior: one common reference, the mean of the two renderers' (their noise then
    # weighs on both alike), scored at the exposure that takes its mean luminance to 0.18 (at
    # exposure 0 it is so dark that relMSE's 0.01 would make it an absolute MSE).
    ref = 0.5 * (ref_a + ref_m)
    y = float(np.mean(ref @ np.array([0.2126, 0.7152, 0.0722])))
    print(f"{name}: reference means aleph {ref_a.mean():.5f}, mitsuba {ref_m.mean():.5f}; "
          f"scored at exposure x{0.18 / y:.2f}", flush=True)
    return toml, res, ref, ref, 0.18 / y


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        return mitsuba_child(json.loads(sys.argv[2]))
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sampler", default="multijitter")
    ap.add_argument("--scenes", nargs="+", default=SCENES, choices=SCENES)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--textured-ref-spp", type=int, default=2048)
    ap.add_argument("--interior-ref-spp", type=int, default=4096)
    args = ap.parse_args()
    mi.set_variant(args.variant)
    os.makedirs(OUT, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes:
            toml, res, ref_a, ref_m, k = setup(name, args, tmp)
            for spp in args.spp:
                for r in range(args.rounds):
                    img_a, t_a = aleph_render(toml, spp, res, args.max_depth, 100 + r, tmp)
                    img_m, t_m = mitsuba_render(name, args, spp, 100 + r, tmp)
                    row = dict(scene=name, spp=spp, round=r, aleph_s=t_a, mitsuba_s=t_m)
                    for who, img, ref in (("aleph", img_a, ref_a), ("mitsuba", img_m, ref_m)):
                        row[f"{who}_relmse"] = rel_mse(k * img, k * ref)
                        row[f"{who}_flip"] = flip_mean(k * img, k * ref)
                    row["eff_relmse"] = (row["mitsuba_relmse"] * t_m) / (row["aleph_relmse"] * t_a)
                    row["eff_flip"] = (row["mitsuba_flip"] ** 2 * t_m) / (row["aleph_flip"] ** 2 * t_a)
                    rows.append(row)
                    print(f"{name} {spp:5d} spp round {r}: aleph {t_a:.3f} s relMSE {row['aleph_relmse']:.5f} FLIP {row['aleph_flip']:.4f} | "
                          f"mitsuba {t_m:.3f} s relMSE {row['mitsuba_relmse']:.5f} FLIP {row['mitsuba_flip']:.4f} | "
                          f"time to equal relMSE aleph/mitsuba advantage {row['eff_relmse']:.2f}x", flush=True)
    with open(os.path.join(OUT, "vs_mitsuba.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    print(f"\n{machine.cpu_description()}")
    print(f"mitsuba {mi.__version__} {args.variant} with its {args.sampler} sampler, depth {args.max_depth}; Cornell box {args.res}² against a "
          f"{args.ref_spp}-spp Mitsuba reference, Lost Empire each against its own {args.textured_ref_spp}-spp reference, "
          f"its interior against the mean of both renderers' {args.interior_ref_spp}-spp references")
    print("scene | spp | aleph s | mitsuba s | samples/s ratio | relMSE aleph | relMSE mitsuba | eq-relMSE advantage | eq-FLIP advantage (medians)")
    for name in args.scenes:
        for spp in args.spp:
            sel = [r for r in rows if r["spp"] == spp and r["scene"] == name]
            med = lambda k: float(np.median([r[k] for r in sel]))
            print(f"{name} | {spp} | {med('aleph_s'):.3f} | {med('mitsuba_s'):.3f} | {med('mitsuba_s') / med('aleph_s'):.2f} | "
                  f"{med('aleph_relmse'):.5f} | {med('mitsuba_relmse'):.5f} | {med('eff_relmse'):.2f}x | {med('eff_flip'):.2f}x")


if __name__ == "__main__":
    main()
