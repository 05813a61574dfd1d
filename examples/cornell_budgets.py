"""The Cornell box at two budgets, perceptual against uniform sampling, judged against a
reference with a metric aleph did not write (HDR-FLIP, NVIDIA's flip-evaluator). Writes examples/out/cornell_budgets.png: the renders,
their sample maps (spp) and the threshold maps (ΔL_T, cd/m²), with the judges' scores.

    pip install "./python[examples]"
    python examples/cornell_budgets.py            # about a minute on two cores

Prints one line per render and exits non-zero if a render at the larger budget is not closer
to the reference than at the smaller one (a check that the judge and the renders are sane).
"""

import pathlib
import sys
import time

import flip_evaluator
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import aleph  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "cornell-box" / "scene.toml"
OUT = pathlib.Path(__file__).resolve().parent / "out"
RESOLUTION = (192, 192)
BUDGETS = (128, 512)  # average spp; the perceptual sampler steers from 128
REFERENCE_SPP = 2048  # uniform, 4× the larger budget, a different seed
PPD = 67.0  # pixels per degree of the viewer (FLIP's default monitor)
# cd/m² per unit of radiance (the scene's render.luminance_scale).
LUMINANCE_SCALE = aleph.load_scene(SCENE)["luminance_scale"]


def render(**kw):
    t0 = time.perf_counter()
    r = aleph.render(SCENE, resolution=RESOLUTION, **kw)
    return r, time.perf_counter() - t0


def judge(reference: np.ndarray, test: aleph.RenderResult) -> dict:
    """Mean HDR-FLIP (Andersson et al. 2021) of the linear radiance, at PPD."""
    _, flip, _ = flip_evaluator.evaluate(
        reference, test.rgb, "HDR", applyMagma=False, parameters={"ppd": PPD}
    )
    return {"flip": float(flip)}


def main() -> int:
    OUT.mkdir(exist_ok=True)
    ref, t_ref = render(spp=REFERENCE_SPP, sampler="uniform", seed=1)
    print(f"reference: uniform {REFERENCE_SPP} spp in {t_ref:.1f} s")
    rows = []
    for spp in BUDGETS:
        for sampler in ("perceptual", "uniform"):
            r, t = render(spp=spp, sampler=sampler)
            score = judge(ref.rgb, r)
            rows.append((sampler, spp, r, score))
            print(
                f"{sampler:>10} {spp:4d} spp: {t:5.1f} s, HDR-FLIP {score['flip']:.4f}, "
                f"spp {r.spp.min()}..{r.spp.max()}"
            )
    figure(ref, rows)
    flips = {(s, spp): sc["flip"] for s, spp, _, sc in rows}
    sane = all(flips[(s, BUDGETS[1])] < flips[(s, BUDGETS[0])] for s in ("perceptual", "uniform"))
    return 0 if sane else 1


def figure(ref: aleph.RenderResult, rows) -> None:
    perceptual = [(spp, r, sc) for s, spp, r, sc in rows if s == "perceptual"]
    fig, ax = plt.subplots(3, 3, figsize=(10.5, 10.5), constrained_layout=True)
    ax[0, 0].imshow(ref.display)
    ax[0, 0].set_title(f"reference, uniform {REFERENCE_SPP} spp")
    # The threshold map of the reference: how much error a viewer would not notice.
    lum = aleph.luminance(ref.rgb) * LUMINANCE_SCALE
    im = ax[1, 0].imshow(aleph.threshold_map(lum, PPD), norm=matplotlib.colors.LogNorm())
    ax[1, 0].set_title("threshold map ΔL_T (cd/m²)")
    fig.colorbar(im, ax=ax[1, 0], shrink=0.8)
    uni = {spp: (r, sc) for s, spp, r, sc in rows if s == "uniform"}
    ax[2, 0].imshow(uni[BUDGETS[0]][0].display)
    ax[2, 0].set_title(f"uniform {BUDGETS[0]} spp, FLIP {uni[BUDGETS[0]][1]['flip']:.4f}")
    for col, (spp, r, sc) in enumerate(perceptual, start=1):
        ax[0, col].imshow(r.display)
        ax[0, col].set_title(f"perceptual {spp} spp, FLIP {sc['flip']:.4f}")
        im = ax[1, col].imshow(r.spp, cmap="viridis", norm=matplotlib.colors.LogNorm())
        ax[1, col].set_title(f"samples per pixel (mean {r.spp.mean():.0f})")
        fig.colorbar(im, ax=ax[1, col], shrink=0.8)
        ratio = r.aovs["Error.Y"] / np.maximum(r.aovs["Threshold.Y"], 1e-30)
        im = ax[2, col].imshow(ratio, cmap="magma", norm=matplotlib.colors.LogNorm(1 / 16, 16))
        ax[2, col].set_title("estimated error / threshold")
        fig.colorbar(im, ax=ax[2, col], shrink=0.8)
    for a in ax.flat:
        a.set_xticks([])
        a.set_yticks([])
    path = OUT / "cornell_budgets.png"
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
