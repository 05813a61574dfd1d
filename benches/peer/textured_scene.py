#!/usr/bin/env python3
"""The bundled Lost Empire (225k triangles, one texture atlas) as one scene both aleph and
Mitsuba 3 render the same way, for ``vs_mitsuba.py``.

What the two renderers cannot share exactly is left out: every material becomes one two-sided
Lambertian reflector textured by the RGB atlas (bilinear, repeat; no alpha cut-outs, no glass,
no emission), lit by a constant sky and a sun. aleph's sun is a disc of 0.01° (it needs a
diameter > 0) and Mitsuba's a ``directional`` light: both one shadow ray per vertex. Two views
(``VIEWS``): the exterior seen from above, and an interior, a roofed hall lit through its
openings. Files go to ``target/peer/lost-empire-bench/``.
"""
import os
import shutil

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
SRC = os.path.join(ROOT, "scenes", "lost-empire")
OUT = os.path.join(ROOT, "target", "peer", "lost-empire-bench")

CAMERA = dict(position=[30.0, 48.0, 62.0], look_at=[-2.0, 22.0, 0.0], up=[0.0, 1.0, 0.0], vfov=50.0)
# Inside a roofed hall of the same world (about 13 × 13 blocks, ceiling 4.5 blocks above the eye),
# lit only through its openings: most light arrives after several bounces, as in an interior.
INTERIOR_CAMERA = dict(position=[35.5, 21.6, -37.5], look_at=[24.0, 21.0, -26.0], up=[0.0, 1.0, 0.0], vfov=70.0)
VIEWS = {"exterior": CAMERA, "interior": INTERIOR_CAMERA}
SUN_DIRECTION = [-0.6, 0.55, 0.45]
SUN_IRRADIANCE = [3.0, 2.8, 2.5]
SKY = [0.5, 0.6, 0.8]


def write_files():
    """The single-material OBJ (absolute indices, positions and texture coordinates), its MTL
    and the atlas; returns the OBJ's path. Reuses them when present."""
    os.makedirs(OUT, exist_ok=True)
    obj = os.path.join(OUT, "lost_empire_atlas.obj")
    if os.path.exists(obj):
        return obj
    shutil.copy(os.path.join(SRC, "lost_empire-RGB.png"), os.path.join(OUT, "atlas.png"))
    with open(os.path.join(OUT, "atlas.mtl"), "w") as f:
        f.write("newmtl atlas\nKd 1 1 1\nmap_Kd atlas.png\n")
    nv = nt = 0
    tmp = obj + ".part"
    with open(os.path.join(SRC, "lost_empire.obj")) as src, open(tmp, "w") as g:
        g.write("mtllib atlas.mtl\nusemtl atlas\n")
        for line in src:
            if line.startswith("v "):
                nv += 1
                g.write(line)
            elif line.startswith("vt "):
                nt += 1
                g.write(line)
            elif line.startswith("f "):
                out = []
                for t in line.split()[1:]:
                    parts = t.split("/")
                    v = int(parts[0])
                    v = v if v > 0 else nv + 1 + v
                    if len(parts) > 1 and parts[1]:
                        vt = int(parts[1])
                        vt = vt if vt > 0 else nt + 1 + vt
                        out.append(f"{v}/{vt}")
                    else:
                        out.append(str(v))
                g.write("f " + " ".join(out) + "\n")
    os.replace(tmp, obj)
    return obj


def aleph_toml(res, spp_hint=16, view="exterior"):
    """aleph's scene file for the benchmark at width `res[0]` × height `res[1]`, seen from
    `view` (a key of ``VIEWS``)."""
    obj = write_files()
    path = os.path.join(OUT, f"scene-{view}-{res[0]}x{res[1]}.toml")
    c = VIEWS[view]
    with open(path, "w") as f:
        f.write(
            f"[camera]\nposition = {c['position']}\nlook_at = {c['look_at']}\nup = {c['up']}\n"
            f"vfov_deg = {c['vfov']}\nresolution = [{res[0]}, {res[1]}]\n"
            f"[render]\nspp = {spp_hint}\n"
            f"[[mesh]]\nfile = \"{os.path.basename(obj)}\"\n"
            f"[[light]]\ntype = \"sun\"\ndirection = {SUN_DIRECTION}\nirradiance = {SUN_IRRADIANCE}\n"
            f"angular_diameter_deg = 0.01\n"
            f"[[light]]\ntype = \"environment\"\nradiance = {SKY}\n"
        )
    return path


def mitsuba_dict(mi, res, max_depth, view="exterior"):
    """Mitsuba's scene dictionary (`max_depth` in Mitsuba's count: bounces + 1), seen from
    `view` (a key of ``VIEWS``)."""
    obj = write_files()
    c = VIEWS[view]
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {
            "type": "perspective",
            "fov": c["vfov"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=c["position"], target=c["look_at"], up=c["up"]),
            "sampler": {"type": "independent"},
            "film": {"type": "hdrfilm", "width": res[0], "height": res[1], "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
        },
        "world": {
            "type": "obj",
            "filename": obj,
            "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
                "type": "bitmap", "filename": os.path.join(OUT, "atlas.png"), "filter_type": "bilinear",
                "wrap_mode": "repeat"}}},
        },
        "sun": {"type": "directional", "direction": [-x for x in SUN_DIRECTION],
                "irradiance": {"type": "rgb", "value": SUN_IRRADIANCE}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": SKY}},
    }
