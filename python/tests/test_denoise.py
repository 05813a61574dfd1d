"""denoise=True in a build with the denoiser (the Rust feature `denoise`; CI builds the package
a second time with it, .ci/run): the arrays are the CLI's `--denoise` EXR bit for bit, and the
raw render is kept as `Noisy.R/G/B`, bit for bit the render without the denoiser. The CLI
($ALEPH_CLI) must be a build with the feature too."""

import numpy as np
import pytest

import aleph
from test_render import assert_matches_exr, exr_channels, same_bits

pytestmark = pytest.mark.skipif(not aleph.DENOISER, reason="built without the denoiser")


def cli_render(cli, scene, tmp_path, *args):
    import subprocess

    out = subprocess.run(
        [cli, "render", scene, *args, "-o", tmp_path / "cli"], capture_output=True, text=True
    )
    assert out.returncode == 0, f"the CLI needs the denoise feature too: {out.stderr}"


def test_denoised_still_equals_cli_exr(tmp_path, cli, cornell):
    size = ["--spp", "4", "--resolution", "48x40"]
    cli_render(cli, cornell, tmp_path, *size, "--denoise")
    r = aleph.render(cornell, spp=4, resolution=(48, 40), denoise=True)
    assert_matches_exr(r.rgb, r.aovs, exr_channels(tmp_path / "cli.exr"))
    raw = aleph.render(cornell, spp=4, resolution=(48, 40))
    for c, name in enumerate("RGB"):
        assert same_bits(r.aovs[f"Noisy.{name}"], raw.rgb[..., c]), name
    assert np.isfinite(r.rgb).all() and not same_bits(r.rgb, raw.rgb)
    albedo = np.stack([r.aovs[f"Denoising Albedo.{c}"] for c in "RGB"], -1)
    assert albedo.min() >= 0 and albedo.max() <= 1
    normal = np.stack([r.aovs[f"Denoising Normal.{c}"] for c in "XYZ"], -1)
    # Means of 16 unit normals per pixel: unit inside a surface, shorter across an edge.
    length = np.linalg.norm(normal, axis=-1)
    assert length.max() <= 1.0001 and np.median(length) > 0.999
    assert "Open Image Denoise" in r.attributes["denoiser"]


def test_fast_denoising_equals_cli_and_is_named(tmp_path, cli, cornell):
    size = ["--spp", "4", "--resolution", "48x40"]
    cli_render(cli, cornell, tmp_path, *size, "--denoise", "--denoise-quality", "fast")
    r = aleph.render(cornell, spp=4, resolution=(48, 40), denoise=True, denoise_quality="fast")
    assert_matches_exr(r.rgb, r.aovs, exr_channels(tmp_path / "cli.exr"))
    assert "quality fast" in r.attributes["denoiser"]
    high = aleph.render(cornell, spp=4, resolution=(48, 40), denoise=True)
    assert "cleanAux true" in high.attributes["denoiser"]
    assert not same_bits(r.rgb, high.rgb)


def test_denoised_sequence_equals_cli_frames(tmp_path, cli, cornell_motion):
    """Reusing frames are denoised after the loop (with no output file too)."""
    args = ["--frames", "2..3", "--spp", "4", "--resolution", "32x32", "--denoise"]
    cli_render(cli, cornell_motion, tmp_path, *args)
    r = aleph.render(cornell_motion, frames=(2, 3), spp=4, resolution=(32, 32), denoise=True)
    assert {"Noisy.R", "History.spp"} <= set(r.aovs)
    for i, f in enumerate(r.frames):
        exr = exr_channels(tmp_path / f"cli.{f:04d}.exr")
        assert_matches_exr(r.rgb[i], {k: v[i] for k, v in r.aovs.items()}, exr)
