"""aleph: a physically based renderer that renders only what a person can see.

A Monte Carlo path tracer whose samples go where a model of the human visual system says the
remaining error is still visible (the threshold map of Ramasubramanian et al. 1999, with Daly's
contrast sensitivity, masking and eye motion, as in Yee et al. 2001). This package exposes the
Rust libraries to Python:

- rendering: :func:`render` (or :class:`RenderJob` then :meth:`RenderJob.render`) returns a
  :class:`RenderResult` whose ``rgb`` is linear radiance in W·sr⁻¹·m⁻² as float32 arrays and
  whose ``aovs`` are the EXR's other channels by name (``spp``, ``Threshold.Y``, ``Error.Y``,
  ``Vector.X``…, ``Depth.Z``, ``Normal.X``…, ``IndexOB``);
- perception on any image: :func:`threshold_map` (cd/m² in, cd/m² out), :func:`diff` (is a
  difference visible?), :func:`tonemap` and the operators by their papers in :mod:`aleph.tmo`.

Errors are :class:`AlephError` subclasses carrying the CLI's messages (naming the file, frame
or option). The GIL is released while rendering and while the perception model runs; Ctrl-C
stops a render cleanly (``KeyboardInterrupt``; no partial file is left).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _aleph
from ._aleph import (
    AlephError,
    JobError,
    OutputError,
    PerceptionError,
    Progress,
    RenderJob,
    SceneError,
)

__version__ = _aleph.__version__
#: Whether this build has Open Image Denoise (``denoise=True``, denoised previews).
DENOISER: bool = _aleph.DENOISER

__all__ = [
    "DENOISER",
    "AlephError",
    "DiffResult",
    "JobError",
    "OutputError",
    "PerceptionError",
    "Progress",
    "RenderJob",
    "RenderResult",
    "SceneError",
    "diff",
    "load_scene",
    "luminance",
    "operators",
    "read_image",
    "render",
    "render_job",
    "threshold_map",
    "tmo",
    "to_srgb8",
    "tonemap",
]

Scene = Union[str, "os.PathLike[str]", Dict[str, Any]]

#: Rec. 709 luminance weights of linear RGB (ITU-R BT.709).
REC709 = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


@dataclass
class RenderResult:
    """What a render returns.

    Attributes:
        rgb: linear radiance, W·sr⁻¹·m⁻², Rec. 709 RGB: float32 ``(H, W, 3)`` for a still,
            ``(F, H, W, 3)`` for frames (the same values as the EXR's R, G, B).
        aovs: the EXR's other channels by name, each ``(H, W)`` (or ``(F, H, W)``):
            ``spp`` uint32 samples per pixel; ``Threshold.Y`` and ``Error.Y`` float32, the
            sampler's last threshold and error (units in ``attributes["thresholdUnits"]``:
            display or scene cd/m²); for frames ``Vector.X/Y/Z/W`` (Blender's Vector pass,
            pixels per frame); ``Depth.Z`` (m), ``Normal.X/Y/Z``, ``IndexOB``; ``History.spp``
            where samples were reused from earlier frames.
        display: the display image (the PNG's pixels), uint8 sRGB ``(H, W, 3)`` or
            ``(F, H, W, 3)``.
        frames: frame numbers (empty for a still).
        stats: per frame: ``mean_spp``, ``samples``, ``passes``, ``converged_fraction``,
            ``wall_s``, ``render_s``, ``decision_s``, ``stop`` (why the sampler stopped), and
            ``reused_spp``/``reused_fraction`` for frames that reused earlier ones.
        attributes: the EXR header's attributes as text (units, scene, sampler, whiteLuminance:
            cd/m² per unit of ``rgb``) of the last frame.
        report: the job's report (``kind``: still or sequence; a sequence's fps, times).
        job: the job that was rendered.
    """

    rgb: np.ndarray
    aovs: Dict[str, np.ndarray]
    display: np.ndarray
    frames: List[int] = field(default_factory=list)
    stats: List[Dict[str, Any]] = field(default_factory=list)
    attributes: Dict[str, str] = field(default_factory=dict)
    report: Dict[str, Any] = field(default_factory=dict)
    job: Optional[RenderJob] = None

    @property
    def spp(self) -> np.ndarray:
        """Samples per pixel, uint32 ``(H, W)`` (``aovs["spp"]``)."""
        return self.aovs["spp"]

    @property
    def luminance(self) -> np.ndarray:
        """Luminance Y of ``rgb`` in radiance units (Rec. 709 weights); multiply by the
        scene's ``render.luminance_scale`` for cd/m²."""
        return luminance(self.rgb)


def load_scene(
    scene: Scene, *, base_dir: Union[None, str, "os.PathLike[str]"] = None
) -> Dict[str, Any]:
    """Loads a scene without rendering it, to see what a job would render.

    Args:
        scene: a scene file or a dict of the scene format's tables (as :func:`render`).
        base_dir: where a dict's relative file names are resolved (default: the working
            directory).

    Returns:
        A dict: ``path``, ``width`` and ``height`` (pixels), ``triangles``,
        ``emissive_triangles``, ``frames`` (the animation's inclusive ``(first, last)``, or
        None for a still), ``fps``, ``spp``, ``seed``, ``max_depth`` (the scene's render
        settings) and ``luminance_scale`` (cd/m² per unit of radiance: multiply luminance by it
        for :func:`threshold_map`).

    Raises:
        SceneError: the scene, a mesh or a texture cannot be loaded (the message names it).
    """
    return _aleph.load_scene(scene, base_dir=base_dir)


def render_job(
    job: RenderJob,
    *,
    threads: Optional[int] = None,
    progress: Optional[Callable[[Progress], Any]] = None,
) -> RenderResult:
    """Renders ``job``; see :func:`render` for ``threads``, ``progress`` and the result.

    Raises:
        SceneError, JobError, OutputError: as the CLI would report them.
        KeyboardInterrupt: after Ctrl-C (frames already written stay; nothing half written).
    """
    frames, report = _aleph.run(job, threads=threads, progress=progress)
    if not frames:
        raise JobError("the job rendered no frame")
    still = len(frames) == 1 and frames[0]["frame"] is None
    stack = (lambda xs: xs[0]) if still else np.stack
    names = frames[0]["aovs"].keys()
    return RenderResult(
        rgb=stack([f["rgb"] for f in frames]),
        aovs={n: stack([f["aovs"][n] for f in frames]) for n in names},
        display=stack([f["display"] for f in frames]),
        frames=[] if still else [f["frame"] for f in frames],
        stats=[f["stats"] for f in frames],
        attributes=frames[-1]["attributes"],
        report=report,
        job=job,
    )


def render(
    scene: Scene,
    *,
    spp: Optional[float] = None,
    sampler: str = "perceptual",
    resolution: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    frames: Union[None, int, Tuple[int, int]] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[Progress], Any]] = None,
    **options: Any,
) -> RenderResult:
    """Renders a scene and returns its arrays.

    Args:
        scene: a scene file (TOML, docs/scene-format.md) as ``str`` or ``os.PathLike``, or a
            dict of the same tables (relative file names resolved in ``base_dir=``, default
            the working directory).
        spp: average samples per pixel (N × pixels in all). None: the perceptual and
            variance samplers run until the error is below threshold; uniform takes the
            scene's ``render.spp``.
        sampler: ``"perceptual"`` (the threshold map decides), ``"uniform"`` or
            ``"variance"`` (Cycles' noise threshold).
        resolution: ``(width, height)`` in pixels instead of the scene's.
        seed: random seed instead of the scene's ``render.seed`` (0 in every bundled scene).
        frames: a frame number or an inclusive ``(first, last)`` pair of an animated scene;
            None renders a still, or every frame of an animated scene.
        threads: worker threads (default all cores); the image does not depend on it.
        progress: called on the calling thread with a :class:`Progress` after every pass,
            frame and at most four times a second while samples are taken; ``p.samples`` is
            the count since the previous call, so ``tqdm.update(p.samples)`` works.
        **options: the other :class:`RenderJob` options: ``time`` (seconds), ``max_depth``,
            ``reuse_window``, ``operator``, ``exposure``, ``fov``, ``ppd``, ``output`` (also
            write STEM.exr and STEM.png, as ``aleph render -o STEM``), ``aov``, ``denoise``,
            ``denoise_quality``, ``preview``, ``base_dir``,
            and ``sampling`` and ``display``: dicts of the job record's tables, for every
            other option (``sampling={"max_spp": 8192, "latitude_ev": 0}``).

    Returns:
        A :class:`RenderResult`. Its arrays equal the EXR ``aleph render`` writes for the same
        job, bit for bit.

    Raises:
        SceneError: the scene, a mesh or a texture cannot be loaded (the message names it).
        JobError: an option is out of range or contradicts another.
        KeyboardInterrupt: Ctrl-C; the render stops within a row of pixels.
    """
    job = RenderJob(
        scene,
        spp=spp,
        sampler=sampler,
        resolution=resolution,
        seed=seed,
        frames=frames,
        **options,
    )
    return render_job(job, threads=threads, progress=progress)


def _plane(a: Any, name: str) -> np.ndarray:
    arr = np.ascontiguousarray(a, dtype=np.float32)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a (H, W) luminance array, got shape {arr.shape}")
    return arr


def _rgb(a: Any, name: str) -> np.ndarray:
    arr = np.ascontiguousarray(a, dtype=np.float32)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"{name}: expected a (H, W, 3) RGB array, got shape {arr.shape}")
    return arr


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Luminance of linear Rec. 709 RGB ``(..., 3)``: 0.2126 R + 0.7152 G + 0.0722 B,
    float32, in the input's units (× the luminance scale for cd/m²)."""
    return np.asarray(rgb, dtype=np.float32) @ REC709


def threshold_map(
    luminance: np.ndarray,
    ppd: Optional[float] = None,
    *,
    fov: Optional[float] = None,
    adaptation_window: float = 1.0,
    masking: bool = True,
    frequency: bool = True,
    parts: bool = False,
) -> Union[np.ndarray, Dict[str, Any]]:
    """The threshold map of an image: the smallest luminance change a viewer could notice at
    each pixel. ΔL_T = ΔL_TVI(L_a) · F: Ward's TVI at the local adaptation luminance, elevated
    by spatial frequency (Daly 1993's CSF) and masking (Daly 1993), per octave band
    (Ramasubramanian, Pattanaik & Greenberg 1999, SIGGRAPH, §4; Yee, Pattanaik & Greenberg
    2001, ACM TOG 20(1), §3–4). The procedure is in the Rust crate's ``perception::threshold``.

    Args:
        luminance: float32 ``(H, W)`` in cd/m² (other real dtypes are converted).
        ppd: pixels per degree of visual angle (default 67.02: a 0.7 m wide 4K monitor seen
            from 0.7 m, FLIP's default). Or give ``fov``.
        fov: horizontal field of view the image fills, degrees.
        adaptation_window: window of the local adaptation luminance, degrees.
        masking, frequency: switch the masking and spatial-frequency elevations.
        parts: also return the adaptation luminance (cd/m²), the elevations and the noise
            threshold contrast, as a dict.

    Returns:
        The threshold ΔL_T in cd/m², float32 ``(H, W)``; with ``parts``, a dict of such arrays
        (``threshold``, ``adaptation``, ``elevation``, ``frequency_elevation``,
        ``masking_elevation``, ``noise_contrast``) and ``ppd``.

    Raises:
        PerceptionError: NaN, infinite or negative luminance, a bad ppd or fov.
        ValueError: not a 2-D array.
    """
    return _aleph.threshold_map(
        _plane(luminance, "luminance"),
        ppd,
        fov=fov,
        adaptation_window=adaptation_window,
        masking=masking,
        frequency=frequency,
        parts=parts,
    )


@dataclass
class DiffResult:
    """The outcome of :func:`diff`.

    Attributes:
        ratio: |L_ref − L_test| / ΔL_T(reference) per pixel, float32 ``(H, W)`` (visible
            above 1).
        visible_pixels: pixels with ratio > 1.
        visible_fraction: visible_pixels / (H × W).
        different: True when ``visible_pixels`` ≥ ``fail_pixels``.
        ppd: the pixels per degree it was judged at.
    """

    ratio: np.ndarray
    visible_pixels: int
    visible_fraction: float
    different: bool
    ppd: float


def diff(
    reference: np.ndarray,
    test: np.ndarray,
    ppd: Optional[float] = None,
    *,
    fov: Optional[float] = None,
    luminance_scale: float = 100.0,
    fail_pixels: int = 100,
) -> DiffResult:
    """Does a viewer see a difference between two images? (Yee & Newman's pdiff, on aleph's
    threshold map: Yee 2004, JGT 9(4).) The threshold map is the reference's alone, so the
    noise of a test image does not mask itself. Luminance only.

    Args:
        reference, test: luminance ``(H, W)`` in cd/m², or linear RGB ``(H, W, 3)`` turned
            into cd/m² with ``luminance_scale`` (cd/m² per unit; 100: value 1 is a 100 cd/m²
            display white, as ``aleph diff``).
        ppd: pixels per degree; default a 45° field of view (pdiff's, as ``aleph diff``).
        fov: horizontal field of view in degrees instead.
        fail_pixels: "different" from this many visibly different pixels (pdiff's 100); at
            least 1.

    Raises:
        PerceptionError: NaN, infinite or negative values, or a ppd or fov that puts outside
            [1e-6, 1000] pixels in a degree; ValueError: shapes differ, fail_pixels is 0.
    """

    def lum(a: np.ndarray, name: str) -> np.ndarray:
        a = np.asarray(a)
        if a.ndim == 3:
            return _plane(luminance(_rgb(a, name)) * np.float32(luminance_scale), name)
        return _plane(a, name)

    d = _aleph.diff(
        lum(reference, "reference"), lum(test, "test"), ppd, fov=fov, fail_pixels=fail_pixels
    )
    return DiffResult(**d)


def tonemap(
    rgb: np.ndarray,
    operator: str = "reinhard",
    *,
    luminance_scale: float = 100.0,
    ppd: Optional[float] = None,
    adaptation: str = "local",
    display_max: Optional[float] = None,
    display_ambient: Optional[float] = None,
) -> np.ndarray:
    """Tone maps linear RGB to display-linear RGB in [0, 1] (apply :func:`to_srgb8` for 8-bit
    sRGB). The operators are in :mod:`aleph.tmo` by their papers; ``operator`` takes their
    names or the CLI's (``exposure``, ``tr``, ``fpsg``, ``wrp``, ``ptyg``, ``reinhard``).

    Args:
        rgb: float32 ``(H, W, 3)``, ``luminance_scale`` cd/m² per unit.
        adaptation: ``"local"`` (Gaussian-weighted mean over 1°), ``"local-geometric"`` or
            ``"global"`` (the log average).
        ppd: pixels per degree for the 1° window (default 67.02).
        display_max, display_ambient: display luminances in cd/m² (default: each operator's).

    Raises:
        PerceptionError: NaN, infinite or negative values, bad display luminances.
        JobError: an unknown operator.
    """
    return _aleph.tonemap(
        _rgb(rgb, "rgb"),
        operator,
        luminance_scale=luminance_scale,
        ppd=ppd,
        adaptation=adaptation,
        display_max=display_max,
        display_ambient=display_ambient,
    )


def to_srgb8(display: np.ndarray) -> np.ndarray:
    """Display-linear RGB in [0, 1] ``(H, W, 3)`` to uint8 sRGB (IEC 61966-2-1), as the
    PNGs hold it."""
    return _aleph.to_srgb8(_rgb(display, "display"))


def read_image(path: Union[str, "os.PathLike[str]"]) -> Tuple[np.ndarray, float]:
    """Reads .exr, .hdr, .png or .jpg as linear RGB: ``(rgb float32 (H, W, 3),
    luminance_scale cd/m² per unit)`` by ``aleph diff``'s rule (the EXR's whiteLuminance,
    else 100; PNG and JPEG are decoded from sRGB, white at 100 cd/m²).

    Raises:
        SceneError: the file is missing or cannot be decoded (the message names it).
    """
    return _aleph.read_image(os.fspath(path))


def operators() -> List[Tuple[str, str]]:
    """The tone operators: ``(name, label with its paper)``."""
    return _aleph.operators()


from . import tmo  # noqa: E402  (needs tonemap above)
