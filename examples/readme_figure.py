"""The README's picture: the bundled Cornell box as `cargo run --release -- render` renders it
(perceptual sampling until the remaining noise is below the threshold map), beside its sample
map and the threshold map the sampler judged it with (the EXR's spp and Threshold.Y).

    python examples/readme_figure.py [OUT.png]      # default docs/images/cornell-maps.png
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import aleph  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main() -> None:
    out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs/images/cornell-maps.png"
    r = aleph.render(ROOT / "scenes/cornell-box/scene.toml")
    s = r.stats[0]
    fig, ax = plt.subplots(1, 3, figsize=(13.5, 4.6), constrained_layout=True)
    ax[0].imshow(r.display)
    ax[0].set_title(f"render: {s['mean_spp']:.0f} spp mean, {s['stop']}")
    im = ax[1].imshow(r.spp, cmap="viridis", norm=matplotlib.colors.LogNorm())
    ax[1].set_title("samples per pixel")
    fig.colorbar(im, ax=ax[1], shrink=0.85)
    # 1e30 marks pixels where every grade of the exposure latitude clips (nothing visible).
    t = np.where(r.aovs["Threshold.Y"] < 1e29, r.aovs["Threshold.Y"], np.nan)
    im = ax[2].imshow(t, cmap="magma", norm=matplotlib.colors.LogNorm())
    ax[2].set_title("threshold map ΔL_T, cd/m² (scene)")
    fig.colorbar(im, ax=ax[2], shrink=0.85)
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    fig.savefig(out, dpi=72)
    print(f"wrote {out}: {s['mean_spp']:.1f} spp mean, {100 * s['converged_fraction']:.1f} % below threshold")


if __name__ == "__main__":
    main()
