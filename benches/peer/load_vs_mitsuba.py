#!/usr/bin/env python3
"""Scene load + BVH build time and peak memory: aleph against Mitsuba 3, on the same OBJ files.

Setup: ``bash benches/peer/setup.sh``. Then::

    benches/peer/.venv/bin/python benches/peer/load_vs_mitsuba.py [--variant llvm_ad_rgb]

Cases: a generated 1,000,000-triangle heightfield (written to ``target/peer/``) and the largest
bundled scene, ``scenes/lost-empire`` (224,998 triangles, textures). Each renderer runs in its own
process under ``/usr/bin/time -v`` (peak RSS), alternating, ``--rounds`` times:

- aleph: ``render --sampler uniform --spp 1 --resolution 64x64``; its ``loaded in … s (BVH
  build … s)`` line gives the load and build times;
- Mitsuba: ``mi.load_dict`` of the OBJ (one shape, diffuse) timed in-process, which includes its
  own acceleration-structure build, then one 64×64 render at 1 spp so its scene is complete.

Prints medians.
"""
import argparse, os, re, statistics, subprocess, sys

import machine  # beside this file

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(ROOT, "target", "peer")
ALEPH = os.path.join(ROOT, "target", "release", "aleph")

MITSUBA_CHILD = r'''
import sys, time, mitsuba as mi
mi.set_variant(sys.argv[1])
t = time.perf_counter()
scene = mi.load_dict({"type": "scene",
    "shape": {"type": "obj", "filename": sys.argv[2], "bsdf": {"type": "diffuse"}},
    "light": {"type": "constant"}, "integrator": {"type": "path"},
    "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 64, "height": 64}}})
load = time.perf_counter() - t
mi.render(scene, spp=1)
print(f"LOAD {load:.4f}")
'''


def heightfield(path, n=708):
    """(n−1)² × 2 ≈ 1.0 M triangles: a bumpy grid."""
    import math
    with open(path, "w") as f:
        for i in range(n):
            for j in range(n):
                x, z = i / (n - 1) * 10 - 5, j / (n - 1) * 10 - 5
                f.write(f"v {x:.5f} {0.2 * math.sin(3 * x) * math.cos(2 * z):.5f} {z:.5f}\n")
        for i in range(n - 1):
            for j in range(n - 1):
                a = i * n + j + 1
                f.write(f"f {a} {a + n} {a + n + 1}\nf {a} {a + n + 1} {a + 1}\n")


def absolute_indices(src, dst):
    """The OBJ's positions and faces with absolute vertex indices (Mitsuba's OBJ reader refuses
    the negative, relative indices lost_empire.obj uses); no texture coordinates or normals."""
    n = 0
    with open(src) as f, open(dst, "w") as g:
        for line in f:
            if line.startswith("v "):
                n += 1
                g.write(line)
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) for t in line.split()[1:]]
                g.write("f " + " ".join(str(i if i > 0 else n + 1 + i) for i in idx) + "\n")


def timed(cmd):
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True)
    out = p.stdout + p.stderr
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{out}")
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", out).group(1)) / 1024
    return out, rss


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    big = os.path.join(OUT, "heightfield-1m.obj")
    if not os.path.exists(big):
        heightfield(big)
    scene_toml = os.path.join(OUT, "heightfield-1m.toml")
    with open(scene_toml, "w") as f:
        f.write('[camera]\nposition = [0.0, 8.0, 8.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov_deg = 40.0\n'
                'resolution = [64, 64]\n[[mesh]]\nfile = "heightfield-1m.obj"\n'
                '[[light]]\ntype = "environment"\nradiance = [1.0, 1.0, 1.0]\n')
    lost = os.path.join(OUT, "lost_empire-absolute.obj")
    if not os.path.exists(lost):
        absolute_indices(os.path.join(ROOT, "scenes", "lost-empire", "lost_empire.obj"), lost)
    cases = [("1M-triangle heightfield", scene_toml, big),
             ("lost-empire (225k; aleph with its textures, Mitsuba positions only)",
              os.path.join(ROOT, "scenes", "lost-empire", "scene.toml"), lost)]
    print(machine.cpu_description(), flush=True)
    for name, toml, obj in cases:
        a_load, a_bvh, a_rss, m_load, m_rss = [], [], [], [], []
        for _ in range(args.rounds):
            out, rss = timed([ALEPH, "render", toml, "--sampler", "uniform", "--spp", "1",
                              "--resolution", "64x64", "-o", os.path.join(OUT, "load-test")])
            m = re.search(r"loaded in ([0-9.]+) s \(BVH build ([0-9.]+) s\)", out)
            a_load.append(float(m.group(1)))
            a_bvh.append(float(m.group(2)))
            a_rss.append(rss)
            out, rss = timed([sys.executable, "-c", MITSUBA_CHILD, args.variant, obj])
            m_load.append(float(re.search(r"LOAD ([0-9.]+)", out).group(1)))
            m_rss.append(rss)
        med = statistics.median
        print(f"{name}: aleph load {med(a_load):.2f} s (BVH build {med(a_bvh):.2f} s), peak {med(a_rss):.0f} MiB | "
              f"mitsuba {args.variant} load {med(m_load):.2f} s, peak {med(m_rss):.0f} MiB | "
              f"load ratio aleph/mitsuba {med(a_load) / med(m_load):.2f}", flush=True)


if __name__ == "__main__":
    main()
