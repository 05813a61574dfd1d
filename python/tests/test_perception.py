"""The perception model on plain arrays, against published values and analytic cases."""

import math

import numpy as np
import pytest

import aleph


def tvi_ward97(la: float) -> float:
    """Ward Larson, Rushmeier & Piatko 1997 (IEEE TVCG 3(4)), eq. 7: the threshold luminance
    ΔL_t(L_a) in cd/m², the combined rod and cone TVI of Ferwerda et al. 1996, written out here
    from the paper, independently of the Rust code."""
    x = math.log10(la)
    if x < -3.94:
        y = -2.86
    elif x < -1.44:
        y = (0.405 * x + 1.6) ** 2.18 - 2.86
    elif x < -0.0184:
        y = x - 0.395
    elif x < 1.9:
        y = (0.249 * x + 0.65) ** 2.7 - 0.72
    else:
        y = x - 1.255
    return 10.0**y


@pytest.mark.parametrize("la", [1e-3, 0.1, 1.0, 30.0, 100.0, 1e4])
def test_flat_field_threshold_is_the_tvi(la):
    """A uniform field has no band contrast, hence no elevation (F = 1): ΔL_T = TVI(L_a),
    L_a the field's luminance. The map reads the TVI from a table interpolated in log2 L_a,
    documented to reproduce it within 0.1 % (perception/src/table.rs): that is the
    tolerance. (Measured: 0.015 % to 0.085 %.)"""
    lum = np.full((64, 96), la, dtype=np.float32)
    t = aleph.threshold_map(lum, 40.0)
    assert t.shape == lum.shape and t.dtype == np.float32
    np.testing.assert_allclose(t, tvi_ward97(la), rtol=1e-3)


def test_parts_of_a_flat_field():
    p = aleph.threshold_map(np.full((32, 32), 50.0, np.float32), 30.0, parts=True)
    np.testing.assert_allclose(p["adaptation"], 50.0, rtol=1e-5)
    np.testing.assert_allclose(p["elevation"], 1.0, rtol=1e-6)
    assert p["ppd"] == 30.0


def test_texture_masks():
    """A visible grating raises the threshold over the flat field's (masking and frequency
    elevation, F > 1), but never past the cap of 10."""
    y, x = np.mgrid[0:128, 0:128]
    grating = (50.0 * (1.0 + 0.5 * np.sin(2 * np.pi * x / 8.0))).astype(np.float32)
    p = aleph.threshold_map(grating, 60.0, parts=True)
    inner = p["elevation"][32:-32, 32:-32]
    assert inner.min() > 1.5 and inner.max() <= 10.0 + 1e-5


def test_float64_and_views_are_accepted():
    lum = np.full((40, 40), 10.0)  # float64
    a = aleph.threshold_map(lum[::2, ::2], 30.0)  # a strided view
    assert a.shape == (20, 20)


def test_diff_sees_a_step_above_threshold_only():
    ref = np.full((64, 64), 100.0, np.float32)
    t = aleph.threshold_map(ref, 30.0)
    below = ref + 0.5 * t
    above = ref.copy()
    above[16:48, 16:48] += 3.0 * t[16:48, 16:48]
    a = aleph.diff(ref, below, 30.0)
    b = aleph.diff(ref, above, 30.0)
    assert a.visible_pixels == 0 and not a.different
    assert b.visible_pixels >= 32 * 32 * 0.9 and b.different
    assert b.ratio.shape == (64, 64)
    with pytest.raises(ValueError, match="fail_pixels"):
        aleph.diff(ref, ref, 30.0, fail_pixels=0)
    # Pixels per degree have the CLI's range.
    with pytest.raises(aleph.PerceptionError, match="1000"):
        aleph.diff(ref, ref, 1e6)


def test_diff_of_rgb_uses_the_luminance_scale():
    rgb = np.full((32, 32, 3), 0.5, np.float32)
    d = aleph.diff(rgb, rgb * 1.001, luminance_scale=100.0)
    assert d.visible_pixels == 0
    assert abs(d.ppd - (16.0 / math.tan(math.radians(22.5)) * math.pi / 180.0)) < 1e-9


def test_operators_by_paper_match_the_cli_names():
    rng = np.random.default_rng(1)
    rgb = rng.uniform(0.0, 4.0, size=(24, 32, 3)).astype(np.float32)
    pairs = [
        (aleph.tmo.tumblin_rushmeier93, "tr"),
        (aleph.tmo.ferwerda96, "fpsg"),
        (aleph.tmo.ward_larson97, "wrp"),
        (aleph.tmo.pattanaik00, "ptyg"),
        (aleph.tmo.reinhard02, "reinhard"),
        (aleph.tmo.exposure, "exposure"),
    ]
    for f, name in pairs:
        out = f(rgb)
        assert out.shape == rgb.shape and out.dtype == np.float32
        assert np.array_equal(out, aleph.tonemap(rgb, name))
        assert 0.0 <= out.min() and out.max() <= 1.0


def test_srgb_encoding_is_iec_61966():
    d = np.array([[[0.0, 0.0031308, 1.0]]], np.float32)
    assert aleph.to_srgb8(d).tolist() == [[[0, 10, 255]]]


@pytest.mark.parametrize("bad", [np.nan, np.inf, -1.0])
def test_bad_luminance_raises_perception_error(bad):
    lum = np.full((16, 16), 10.0, np.float32)
    lum[3, 4] = bad
    with pytest.raises(aleph.PerceptionError):
        aleph.threshold_map(lum, 30.0)


def test_wrong_shape_is_value_error():
    with pytest.raises(ValueError, match="luminance"):
        aleph.threshold_map(np.ones((4, 4, 3), np.float32))
    with pytest.raises(ValueError, match="same size"):
        aleph.diff(np.ones((4, 4)), np.ones((4, 5)))


def test_bad_ppd_raises():
    with pytest.raises(aleph.PerceptionError, match="pixels per degree"):
        aleph.threshold_map(np.ones((8, 8), np.float32), -2.0)
