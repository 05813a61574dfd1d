#!/usr/bin/env python3
"""aleph's BVH against Embree (inside Mitsuba 3) on the same rays: is ray casting the gap?

`vs_mitsuba.py` times whole renders; Mitsuba's ``llvm_ad_rgb`` variant traces paths as
wavefronts across SIMD lanes and casts them through Embree, aleph traces one path at a time
through its own eight-wide BVH. This script separates the ray casting: the ``rays`` binary
(``benches/src/bin/rays.rs``) makes camera, bounce and shadow rays on a scene, times aleph's
``Geometry::intersect`` / ``unoccluded`` on them (all cores, median of rounds) and writes them
out; then a child process of this script loads the same geometry in Mitsuba and times
``Scene.ray_intersect_preliminary`` (closest hit, no surface record) and ``Scene.ray_test``
(occlusion) on the same rays as one wavefront each (after a warm-up call that compiles the
kernel; ``dr.sync_thread`` after each), and checks that both find the same hits. Each renderer
runs in a process of its own, one after the other.

Setup as for ``vs_mitsuba.py`` (``bash benches/peer/setup.sh``), then::

    cargo build --release -p aleph-benches --bin rays
    benches/peer/.venv/bin/python benches/peer/vs_embree_rays.py [--view exterior|interior]
        [--res 640 400] [--rounds 5] [--variant llvm_ad_rgb]

The scene is ``textured_scene.py``'s Lost Empire (225k triangles, the same OBJ for both). The
ratio printed is aleph's rays per second over Mitsuba's (> 1: aleph casts faster).
"""
import argparse, json, os, statistics, subprocess, sys, time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import textured_scene  # noqa: E402 (beside this file)
import machine  # noqa: E402
RAYS = os.path.join(ROOT, "target", "release", "rays")
OUT = os.path.join(ROOT, "target", "peer")
SETS = ["camera", "bounce", "shadow"]


def read_sets(path):
    """The ray sets the ``rays`` binary wrote: per set (origins, directions, t_max, answers)."""
    buf = np.fromfile(path, dtype=np.uint8)
    at, sets = 0, []
    for _ in SETS:
        n = int(np.frombuffer(buf[at:at + 4], dtype="<u4")[0])
        at += 4
        rays = np.frombuffer(buf[at:at + 28 * n], dtype="<f4").reshape(n, 7)
        at += 28 * n
        answers = np.frombuffer(buf[at:at + 4 * n], dtype="<f4")
        at += 4 * n
        sets.append((rays[:, 0:3], rays[:, 3:6], rays[:, 6], answers))
    return sets


def mitsuba_child(spec):
    """In its own process: Mitsuba's rays per second and answers for each set."""
    import mitsuba as mi
    import drjit as dr
    mi.set_variant(spec["variant"])
    scene = mi.load_dict(textured_scene.mitsuba_dict(mi, spec["res"], 9, view=spec["view"]))
    out = {}
    for name, (o, d, tmax, _) in zip(SETS, read_sets(spec["file"])):
        ray = mi.Ray3f(mi.Point3f(*[mi.Float(np.ascontiguousarray(o[:, k])) for k in range(3)]),
                       mi.Vector3f(*[mi.Float(np.ascontiguousarray(d[:, k])) for k in range(3)]))
        ray.maxt = mi.Float(np.minimum(tmax, np.float32(3.0e38)))
        dr.eval(ray)
        cast = (lambda r: scene.ray_test(r)) if name == "shadow" else \
            (lambda r: scene.ray_intersect_preliminary(r).t)
        res = cast(ray)
        dr.eval(res)
        dr.sync_thread()
        rates = []
        for _ in range(spec["rounds"]):
            t0 = time.perf_counter()
            res = cast(ray)
            dr.eval(res)
            dr.sync_thread()
            rates.append(len(o) / (time.perf_counter() - t0))
        ans = np.array(res, dtype=np.float32)
        if name == "shadow":
            ans = (~np.array(res, dtype=bool)).astype(np.float32)
        else:
            ans = np.where(np.isfinite(ans) & (ans < 1e30), ans, np.inf)
        out[name] = {"rate": statistics.median(rates), "answers": ans.tolist()}
    print(json.dumps(out))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--view", default="exterior", choices=sorted(textured_scene.VIEWS))
    ap.add_argument("--res", type=int, nargs=2, default=[640, 400])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    a = ap.parse_args()
    if not os.path.exists(RAYS):
        sys.exit(f"{RAYS} missing: cargo build --release -p aleph-benches --bin rays")
    toml = textured_scene.aleph_toml(tuple(a.res), view=a.view)
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, f"rays-{a.view}-{a.res[0]}x{a.res[1]}.bin")
    p = subprocess.run([RAYS, toml, path, "--resolution", f"{a.res[0]}x{a.res[1]}",
                        "--rounds", str(a.rounds)], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"rays failed: {p.stderr.strip()}")
    aleph = {}
    for line in p.stdout.splitlines():
        name, rest = line.split(":", 1)
        aleph[name] = float(rest.split("rays/s")[0].split(",")[-1].split()[0]) * 1e6
    spec = {"variant": a.variant, "res": a.res, "view": a.view, "file": path, "rounds": a.rounds}
    c = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(spec)],
                       capture_output=True, text=True)
    if c.returncode != 0:
        sys.exit(f"Mitsuba child failed: {c.stderr.strip()[-2000:]}")
    mits = json.loads(c.stdout.strip().splitlines()[-1])
    print(machine.cpu_description())
    print(f"Lost Empire {a.view}, {a.res[0]}x{a.res[1]}, Mitsuba {a.variant}, median of {a.rounds} rounds")
    print("| rays | count | aleph M rays/s | Mitsuba M rays/s | aleph / Mitsuba | same answer |")
    print("|---|---|---|---|---|---|")
    for name, (_, _, _, ans) in zip(SETS, read_sets(path)):
        m = np.array(mits[name]["answers"], dtype=np.float32)
        if name == "shadow":
            same = np.mean(m == ans)
        else:
            both = np.isfinite(m) & np.isfinite(ans)
            with np.errstate(invalid="ignore"):  # inf - inf where both miss
                close = np.abs(m - ans) <= 1e-3 * np.maximum(1.0, np.abs(ans))
            same = np.mean(np.where(both, close, np.isfinite(m) == np.isfinite(ans)))
        ra, rm = aleph[name], mits[name]["rate"]
        print(f"| {name} | {len(ans)} | {ra / 1e6:.2f} | {rm / 1e6:.2f} | {ra / rm:.2f}x | {100 * same:.2f} % |")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        mitsuba_child(json.loads(sys.argv[2]))
    else:
        main()
