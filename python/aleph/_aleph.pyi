"""Type stubs of the extension module ``aleph._aleph`` (Rust, PyO3). Use the wrappers in
``aleph`` (``aleph.render``, ``aleph.threshold_map``…), which convert arrays and build the
results; these are the raw entry points they call."""

import os
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
#: Whether this build has Open Image Denoise (the Rust feature ``denoise``): ``denoise=True``
#: and denoised previews need it.
DENOISER: bool

class AlephError(Exception):
    """Base class of aleph's errors; the message names the file, frame or setting."""

class SceneError(AlephError):
    """A scene, mesh, texture or image cannot be loaded (the message names the file)."""

class JobError(AlephError):
    """A job or setting is out of range or contradictory (the message names the option and
    its command-line flag)."""

class PerceptionError(AlephError):
    """The perception model rejects an image or a parameter (NaN, negative, wrong size)."""

class OutputError(AlephError):
    """An output file cannot be written (the message names the file)."""

class RenderJob:
    """A render job: what to render, as one record (the library's ``RenderJob``; its TOML is
    the record a farm manifest and every partial film keep). Options default as
    ``aleph render``'s flags, so the same options give the same pixels.

    Args:
        scene: a scene file (``str``/``os.PathLike``, made absolute) or a dict of the scene
            format's tables (docs/scene-format.md).
        spp: average samples per pixel, ≥ 1 (``--spp``).
        time: seconds of rendering (``--time``).
        sampler: ``"perceptual"``, ``"uniform"`` or ``"variance"`` (``--sampler``).
        resolution: ``(width, height)`` pixels (``--resolution``).
        seed: random seed (``--seed``; None: the scene's ``render.seed``).
        max_depth: maximum path depth (``--max-depth``).
        frames: a frame or an inclusive ``(first, last)`` pair (``--frame``/``--frames``).
        reuse_window: frames whose samples a frame may reuse (``--reuse-window``; None: 15 for
            a perceptual sequence, else 0).
        operator: tone operator of the display image (``--tonemap``): ``exposure``, ``tr``,
            ``fpsg``, ``wrp``, ``ptyg``, ``reinhard`` or their papers' names.
        exposure: exposure in stops for the display image (``--exposure``).
        fov: horizontal field of view the image fills, degrees (``--fov``).
        ppd: pixels per degree of the viewer (``--ppd``).
        output: also write OUTPUT.exr and OUTPUT.png (``-o``; numbered for frames).
        aov: also write the false-colour OUTPUT.spp.png and OUTPUT.ratio.png (``--aov``).
        denoise: denoise with Open Image Denoise (``--denoise``): ``rgb`` is the denoised
            image and the aovs add ``Noisy.R/G/B`` (the render), ``Denoising Albedo.R/G/B``
            and ``Denoising Normal.X/Y/Z``; a JobError unless ``DENOISER`` (a build with the
            ``denoise`` feature, docs/python.md).
        denoise_quality: the model of the final denoising (``--denoise-quality``):
            ``"high"`` (OIDN's high-quality filter, its large model for clean auxiliary
            images up to 16 spp) or ``"fast"`` (OIDN's fast filter); a JobError for another
            name, or for ``"fast"`` without ``denoise``.
        preview: a progressive preview of a still (``--preview``): the perceptual sampler from
            2 spp, OUTPUT.png rewritten atomically after every pass until the perceptual stop
            or ``time``; a JobError with frames, another sampler or an animated scene.
        base_dir: where a dict scene's relative file names are resolved (default: the
            working directory).
        sampling: the job record's ``[sampling]`` table as a dict, every option of the
            adaptive loop by its TOML name: ``min_spp``, ``max_spp``, ``steer_from_spp``,
            ``converged_fraction``, ``visibility`` (``"display"``/``"scene"``),
            ``noise_threshold``, ``guide_spp``, ``error_estimate``, ``saliency``,
            ``adaptation_window_deg``, ``latitude_ev``, ``ppd``, ``use_velocity``,
            ``reuse_window``, ``reuse_memory_gib`` (``--reuse-memory``, default 8). Omitted
            fields keep their defaults; the keyword options above override it.
        display: the record's ``[display]`` table: ``operator``, ``exposure_ev``,
            ``adaptation``, ``max_cd_m2``, ``ambient_cd_m2``, ``fov_deg``.

    Raises:
        JobError: an option out of range or contradicting another.
        TypeError: a scene that is neither a path nor a dict.
    """

    def __init__(
        self,
        scene: Union[str, os.PathLike[str], Dict[str, Any]],
        *,
        spp: Optional[float] = None,
        time: Optional[float] = None,
        sampler: str = "perceptual",
        resolution: Optional[Tuple[int, int]] = None,
        seed: Optional[int] = None,
        max_depth: Optional[int] = None,
        frames: Union[None, int, Tuple[int, int]] = None,
        reuse_window: Optional[int] = None,
        operator: Optional[str] = None,
        exposure: Optional[float] = None,
        fov: Optional[float] = None,
        ppd: Optional[float] = None,
        output: Union[None, str, os.PathLike[str]] = None,
        aov: bool = False,
        denoise: bool = False,
        denoise_quality: str = "high",
        preview: bool = False,
        base_dir: Union[None, str, os.PathLike[str]] = None,
        sampling: Optional[Dict[str, Any]] = None,
        display: Optional[Dict[str, Any]] = None,
    ) -> None: ...
    @staticmethod
    def from_toml(text: str) -> RenderJob:
        """A job from its TOML record. Raises JobError for another version or an unknown
        field."""
    def to_toml(self) -> str:
        """The job's TOML record."""
    @property
    def scene(self) -> str:
        """The scene file (for a dict: ``BASE_DIR/<dict>``)."""
    @property
    def output(self) -> Optional[str]:
        """The output stem, or None."""
    @property
    def sampler(self) -> str:
        """The sampler's name."""

class Progress:
    """A progress report, passed to the ``progress`` callback."""

    kind: str
    """``"samples"`` (samples were taken), ``"pass"`` (a pass ended) or ``"frame"``."""
    frame: Optional[int]
    """The frame number in a sequence, else None."""
    samples: int
    """Samples taken since the previous report."""
    total_samples: int
    """Samples taken so far by the job."""
    expected_samples: Optional[int]
    """spp × pixels × frames when the budget fixes it; None when rendering until converged."""
    pass_index: Optional[int]
    """For ``"pass"``: the pass number (0 = the first, uniform pass)."""
    mean_spp: Optional[float]
    """For ``"pass"``: mean samples per pixel of the frame after the pass."""
    converged_fraction: Optional[float]
    """For ``"pass"``: fraction of pixels whose error is below the threshold."""

def run(
    job: RenderJob,
    *,
    threads: Optional[int] = None,
    progress: Optional[Callable[[Progress], Any]] = None,
) -> Tuple[List[Dict[str, Any]], Dict[str, Any]]:
    """Renders ``job``; returns its frames (dicts with ``frame``, ``rgb`` float32 (H, W, 3)
    W·sr⁻¹·m⁻², ``aovs`` {EXR channel: (H, W)}, ``display`` uint8 (H, W, 3), ``attributes``,
    ``stats``) and the job's report. Raises SceneError, JobError, OutputError,
    KeyboardInterrupt (Ctrl-C) or the callback's exception."""

def load_scene(
    scene: Union[str, os.PathLike[str], Dict[str, Any]],
    *,
    base_dir: Union[None, str, os.PathLike[str]] = None,
) -> Dict[str, Any]:
    """The scene's ``path``, ``width``, ``height``, ``triangles``, ``emissive_triangles``,
    ``frames`` ((first, last) or None), ``fps``, ``spp``, ``seed``, ``max_depth`` and
    ``luminance_scale`` (cd/m² per unit). Raises SceneError."""

def threshold_map(
    luminance: npt.NDArray[np.float32],
    ppd: Optional[float] = None,
    *,
    fov: Optional[float] = None,
    adaptation_window: float = 1.0,
    masking: bool = True,
    frequency: bool = True,
    parts: bool = False,
) -> Union[npt.NDArray[np.float32], Dict[str, Any]]:
    """Threshold map ΔL_T (cd/m², (H, W)) of C-contiguous float32 luminance (cd/m², (H, W))."""

def diff(
    reference: npt.NDArray[np.float32],
    test: npt.NDArray[np.float32],
    ppd: Optional[float] = None,
    *,
    fov: Optional[float] = None,
    fail_pixels: int = 100,
) -> Dict[str, Any]:
    """Visible difference of two luminance images (cd/m², (H, W)): ``ratio``,
    ``visible_pixels``, ``visible_fraction``, ``different``, ``ppd``."""

def tonemap(
    rgb: npt.NDArray[np.float32],
    operator: str = "reinhard",
    *,
    luminance_scale: float = 100.0,
    ppd: Optional[float] = None,
    adaptation: str = "local",
    display_max: Optional[float] = None,
    display_ambient: Optional[float] = None,
) -> npt.NDArray[np.float32]:
    """Display-linear RGB in [0, 1], (H, W, 3), of linear RGB (H, W, 3)."""

def to_srgb8(display: npt.NDArray[np.float32]) -> npt.NDArray[np.uint8]:
    """8-bit sRGB (H, W, 3) of display-linear RGB (H, W, 3)."""

def read_image(path: str) -> Tuple[npt.NDArray[np.float32], float]:
    """(linear RGB float32 (H, W, 3), cd/m² per unit) of an .exr, .hdr, .png or .jpg."""

def operators() -> List[Tuple[str, str]]:
    """The tone operators: (name, label with the paper)."""
