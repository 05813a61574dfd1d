#!/usr/bin/env python3
"""Mitsuba 3 as a peer for aleph, on the Cornell box.

Two jobs (``pip install mitsuba`` first; nothing here is needed by the tests or CI):

``speed``      samples/s of Mitsuba's ``scalar_rgb`` path tracer on its built-in Cornell box and on
               aleph's bundled box (McGuire's OBJ, converted here), 256x256, box filter, same
               max depth as aleph; prints one line per scene. Run aleph's own summary in the
               same session to compare (``bash benches/peer/compare.sh`` does both).
``reference``  an independent reference of aleph's bundled box: K renders with different seeds,
               written as an EXR whose R,G,B channels are the mean and whose SE.R, SE.G, SE.B, SE.Y
               channels are the standard error of that mean (spread of the K renders / sqrt K;
               Y = Rec.709 luminance).
"""
import argparse, os, sys, tempfile, time

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
OBJ = os.path.join(ROOT, "scenes", "cornell-box", "CornellBox-Original.obj")
MTL = os.path.join(ROOT, "scenes", "cornell-box", "CornellBox-Original.mtl")


def read_mtl(path):
    mats, cur = {}, None
    for line in open(path):
        t = line.split("#")[0].split()
        if not t:
            continue
        if t[0] == "newmtl":
            cur = t[1]
            mats[cur] = {}
        elif t[0] in ("Kd", "Ke") and cur:
            mats[cur][t[0]] = [float(x) for x in t[1:4]]
    return mats


def split_obj(path, outdir):
    """Writes one triangle OBJ per material (Mitsuba gives one BSDF per shape)."""
    verts, groups, cur = [], {}, None
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            verts.append(t[1:4])
        elif t[0] == "usemtl":
            cur = t[1]
            groups.setdefault(cur, [])
        elif t[0] == "f":
            idx = [int(x.split("/")[0]) for x in t[1:]]
            idx = [i if i > 0 else len(verts) + 1 + i for i in idx]
            for k in range(1, len(idx) - 1):
                groups[cur].append((idx[0], idx[k], idx[k + 1]))
    files = {}
    for name, tris in groups.items():
        fn = os.path.join(outdir, f"{name}.obj")
        with open(fn, "w") as f:
            used = sorted({i for tri in tris for i in tri})
            remap = {old: new + 1 for new, old in enumerate(used)}
            for old in used:
                f.write("v " + " ".join(verts[old - 1]) + "\n")
            for a, b, c in tris:
                f.write(f"f {remap[a]} {remap[b]} {remap[c]}\n")
        files[name] = fn
    return files


def aleph_box(res, max_depth, outdir, seed=0):
    mats = read_mtl(MTL)
    files = split_obj(OBJ, outdir)
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {
            "type": "perspective",
            "fov": 39.3077,
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0, 0.989, 3.883], target=[0, 0.989, 0], up=[0, 1, 0]
            ),
            "sampler": {"type": "independent", "seed": seed},
            "film": {
                "type": "hdrfilm",
                "width": res,
                "height": res,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
        },
    }
    for name, fn in files.items():
        m = mats[name]
        shape = {
            "type": "obj",
            "filename": fn,
            "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["Kd"]}}},
        }
        if any(v > 0 for v in m.get("Ke", [0, 0, 0])):
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["Ke"]}}
        d[name] = shape
    return d


def builtin_box(res, max_depth):
    d = mi.cornell_box()
    d["integrator"]["max_depth"] = max_depth
    d["sensor"]["film"]["width"] = res
    d["sensor"]["film"]["height"] = res
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    return d


def speed(args):
    mi.set_variant("scalar_rgb")
    with tempfile.TemporaryDirectory() as tmp:
        for name, d in (("builtin", builtin_box(args.res, args.max_depth)), ("aleph-box", aleph_box(args.res, args.max_depth, tmp))):
            scene = mi.load_dict(d)
            mi.render(scene, spp=2)
            t = time.perf_counter()
            mi.render(scene, spp=args.spp)
            dt = time.perf_counter() - t
            n = args.res * args.res * args.spp
            print(f"mitsuba {mi.__version__} scalar_rgb {name} {args.res}x{args.res} {args.spp} spp depth {args.max_depth}: "
                  f"{dt:.2f} s, {n / dt / 1e6:.3f} M samples/s")


def reference(args):
    import numpy as np
    mi.set_variant("scalar_rgb")
    acc, acc2 = None, None
    w = np.array([0.2126, 0.7152, 0.0722])
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.k):
            scene = mi.load_dict(aleph_box(args.res, args.max_depth, tmp, seed=1000 + k))
            img = np.array(mi.render(scene, spp=args.spp, seed=1000 + k), dtype=np.float64)[:, :, :3]
            img = np.concatenate([img, (img @ w)[:, :, None]], axis=2)  # R, G, B, Y
            acc = img if acc is None else acc + img
            acc2 = img * img if acc2 is None else acc2 + img * img
            print(f"render {k + 1}/{args.k}", file=sys.stderr)
    mean = acc / args.k
    var = np.maximum(acc2 / args.k - mean * mean, 0) * args.k / (args.k - 1)
    se = np.sqrt(var / args.k)
    bmp = mi.Bitmap(np.concatenate([mean[:, :, :3], se], axis=2).astype(np.float32),
                    channel_names=["R", "G", "B", "SE.R", "SE.G", "SE.B", "SE.Y"])
    bmp.write(args.out)
    print(f"wrote {args.out}: {args.k} x {args.spp} spp, mean luminance {np.mean(mean[:, :, 3]):.5f}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("speed")
    s.add_argument("--res", type=int, default=256)
    s.add_argument("--spp", type=int, default=64)
    s.add_argument("--max-depth", type=int, default=64)
    r = sub.add_parser("reference")
    r.add_argument("--res", type=int, default=32)
    r.add_argument("--spp", type=int, default=4096)
    r.add_argument("--k", type=int, default=16)
    r.add_argument("--max-depth", type=int, default=64)
    r.add_argument("--out", default=os.path.join(ROOT, "tests", "data", "cornell_mitsuba_32.exr"))
    args = p.parse_args()
    {"speed": speed, "reference": reference}[args.cmd](args)


if __name__ == "__main__":
    main()
