"""Rendering from Python: the arrays equal the CLI's EXR bit for bit, for stills and
sequences, with every sampler; scene dictionaries; threads; progress; errors."""

import pathlib
import subprocess
import sys
import time

import numpy as np
import OpenEXR
import pytest

import aleph

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def exr_channels(path: pathlib.Path) -> dict:
    """Every channel of a single-part EXR, read by the OpenEXR library (not aleph's)."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(c.pixels) for name, c in f.channels().items()}


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def assert_matches_exr(rgb, aovs, exr):
    assert set(exr) == {"R", "G", "B"} | set(aovs)
    for c, name in enumerate("RGB"):
        assert same_bits(rgb[..., c], exr[name]), name
    for name, plane in aovs.items():
        assert same_bits(plane, exr[name]), name


@pytest.mark.parametrize(
    "sampler,spp",
    # The adaptive samplers steer from 128 spp (below, they sample uniformly).
    [("perceptual", 160), ("uniform", 6), ("variance", 160)],
)
def test_still_equals_cli_exr(tmp_path, cli, cornell, sampler, spp):
    args = ["--spp", str(spp), "--resolution", "48x40", "--sampler", sampler]
    subprocess.run(
        [cli, "render", cornell, *args, "-o", tmp_path / "cli"], check=True, capture_output=True
    )
    r = aleph.render(cornell, spp=spp, resolution=(48, 40), sampler=sampler)
    assert r.rgb.shape == (40, 48, 3) and r.rgb.dtype == np.float32
    assert r.spp.dtype == np.uint32 and r.spp.shape == (40, 48)
    assert_matches_exr(r.rgb, r.aovs, exr_channels(tmp_path / "cli.exr"))
    if sampler != "uniform":
        assert {"Threshold.Y", "Error.Y"} <= set(r.aovs)
        assert r.spp.min() < r.spp.max()  # it steered
    # Mean spp is the budget: spp × pixels in all.
    assert int(r.spp.sum()) == spp * 48 * 40 == r.stats[0]["samples"]
    # The EXR's luminance scale (the scene's default: 683 cd/m² per unit of radiance).
    assert float(r.attributes["whiteLuminance"]) == 683.0


def test_written_files_equal_cli_files(tmp_path, cli, cornell):
    """output= writes the same EXR and PNG bytes as `aleph render -o`."""
    subprocess.run(
        [cli, "render", cornell, "--spp", "4", "--resolution", "40x32", "-o", tmp_path / "cli"],
        check=True,
        capture_output=True,
    )
    r = aleph.render(cornell, spp=4, resolution=(40, 32), output=tmp_path / "py")
    for ext in ("exr", "png"):
        assert (tmp_path / f"py.{ext}").read_bytes() == (tmp_path / f"cli.{ext}").read_bytes()
    assert r.display.dtype == np.uint8 and r.display.shape == (32, 40, 3)


def test_sequence_equals_cli_frames(tmp_path, cli, cornell_motion):
    """Frames 2–3 of the moving sphere (reusing frame 0–1's samples: a group of the default
    window starts at frame 0) against the CLI's numbered EXRs."""
    subprocess.run(
        [cli, "render", cornell_motion, "--frames", "2..3", "--spp", "4",
         "--resolution", "32x32", "-o", tmp_path / "seq"],
        check=True,
        capture_output=True,
    )
    r = aleph.render(cornell_motion, frames=(2, 3), spp=4, resolution=(32, 32))
    assert r.frames == [2, 3]
    assert r.rgb.shape == (2, 32, 32, 3)
    assert {"Vector.X", "History.spp"} <= set(r.aovs)
    for i, f in enumerate(r.frames):
        exr = exr_channels(tmp_path / f"seq.{f:04d}.exr")
        assert_matches_exr(r.rgb[i], {k: v[i] for k, v in r.aovs.items()}, exr)
    assert r.report["kind"] == "sequence"


def test_dict_scene_equals_file(cornell):
    desc = tomllib.loads(cornell.read_text())
    a = aleph.render(cornell, spp=2, resolution=(24, 24), sampler="uniform")
    b = aleph.render(
        desc, spp=2, resolution=(24, 24), sampler="uniform", base_dir=cornell.parent
    )
    assert same_bits(a.rgb, b.rgb)


def test_threads_do_not_change_pixels(cornell):
    a = aleph.render(cornell, spp=16, resolution=(32, 32), threads=1)
    b = aleph.render(cornell, spp=16, resolution=(32, 32), threads=2)
    assert same_bits(a.rgb, b.rgb) and same_bits(a.spp, b.spp)


def test_progress_counts_every_sample(cornell):
    seen = []
    r = aleph.render(cornell, spp=24, resolution=(32, 32), progress=seen.append)
    assert all(isinstance(p, aleph.Progress) for p in seen)
    assert sum(p.samples for p in seen) == int(r.spp.sum())
    assert seen[-1].kind == "frame" and seen[-1].total_samples == 24 * 32 * 32
    assert all(p.expected_samples == 24 * 32 * 32 for p in seen)
    passes = [p for p in seen if p.kind == "pass"]
    assert [p.pass_index for p in passes] == list(range(len(passes))) and passes


def test_job_record_round_trips(cornell):
    job = aleph.RenderJob(cornell, spp=8, sampler="variance", resolution=(16, 16))
    again = aleph.RenderJob.from_toml(job.to_toml())
    assert again.to_toml() == job.to_toml()
    assert same_bits(aleph.render_job(job).rgb, aleph.render_job(again).rgb)


def test_missing_scene_names_the_file(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(aleph.SceneError, match="nope.toml"):
        aleph.render(missing)


def test_unknown_scene_key_names_the_key(cornell):
    desc = tomllib.loads(cornell.read_text())
    desc["camera"]["lens_flare"] = True
    with pytest.raises(aleph.SceneError, match="lens_flare"):
        aleph.render(desc, spp=1, base_dir=cornell.parent)


@pytest.mark.parametrize(
    "kw,words",
    [
        ({"sampler": "magic"}, "sampler"),
        ({"spp": 0.5}, "spp"),
        ({"reuse_window": 3}, "sequence"),
        ({"sampling": {"reuse_memory_gib": 0.0}}, "reuse-memory"),
        ({"operator": "nope"}, "operator"),
        ({"threads": 0}, "threads"),
    ],
)
def test_bad_options_raise_job_error(cornell, kw, words):
    with pytest.raises(aleph.JobError, match=words):
        aleph.render(cornell, resolution=(8, 8), **kw)
    assert issubclass(aleph.JobError, aleph.AlephError)


def test_bad_scene_type_is_type_error():
    with pytest.raises(TypeError, match="scene"):
        aleph.render(42)


@pytest.mark.parametrize(
    "edit,kind",
    [
        (lambda t: t.replace("[camera]", "[camera]\nlens_flare = true"), aleph.SceneError),
        (lambda t: t.replace('file = "CornellBox-Original.obj"', 'file = "missing.obj"'),
         aleph.SceneError),
        (lambda t: t.replace("resolution = [512, 512]", "resolution = [0, 512]"),
         aleph.SceneError),
    ],
)
def test_exception_carries_the_cli_message(tmp_path, cli, cornell, edit, kind):
    """A broken scene file: the exception's message is the one `aleph render` prints (after
    its "aleph: error: " prefix), naming the file."""
    for f in cornell.parent.iterdir():
        (tmp_path / f.name).write_bytes(f.read_bytes())
    scene = tmp_path / "scene.toml"
    scene.write_text(edit(scene.read_text()))
    out = subprocess.run(
        [cli, "render", scene, "-o", tmp_path / "out"], capture_output=True, text=True
    )
    assert out.returncode != 0
    with pytest.raises(kind) as e:
        aleph.render(scene)
    assert str(scene) in str(e.value)
    assert f"aleph: error: {e.value}" in out.stderr


def test_load_scene_describes_without_rendering(cornell, cornell_motion):
    still = aleph.load_scene(cornell)
    assert (still["width"], still["height"]) == (512, 512)
    assert still["frames"] is None and still["luminance_scale"] > 0
    # McGuire's CornellBox-Original: 2 emissive triangles (the ceiling light).
    assert still["emissive_triangles"] == 2 and still["triangles"] > 30
    motion = aleph.load_scene(cornell_motion)
    # "2 s at 24 fps (frames 0-47)", as the scene file says.
    assert motion["frames"] == (0, 47) and motion["fps"] == 24.0
    with pytest.raises(aleph.SceneError):
        aleph.load_scene(cornell.parent / "missing.toml")


def test_the_gil_is_released_while_rendering(cornell):
    """Another Python thread keeps running during a render: it counts while the render takes
    about a second. With the GIL held it would count only between progress calls."""
    import threading

    ticks = 0
    done = threading.Event()

    def count():
        nonlocal ticks
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    t0 = time.monotonic()
    try:
        aleph.render(cornell, spp=64, resolution=(128, 128), sampler="uniform", threads=1)
    finally:
        done.set()
        t.join()
    elapsed = time.monotonic() - t0
    # One tick per millisecond at most; allow a factor of ten for a busy machine.
    assert ticks > 100 * elapsed, (ticks, elapsed)


def test_record_tables_reach_every_option(tmp_path, cli, cornell):
    """sampling= and display= set the options without keywords of their own, as the CLI's
    flags do (same EXR), and refuse a field the record does not have."""
    flags = ["--max-spp", "300", "--latitude", "0", "--steer-from", "100", "--display-max", "200"]
    subprocess.run(
        [cli, "render", cornell, "--spp", "150", "--resolution", "40x32", *flags,
         "-o", tmp_path / "cli"],
        check=True,
        capture_output=True,
    )
    job = aleph.RenderJob(
        cornell,
        spp=150,
        resolution=(40, 32),
        sampling={"max_spp": 300, "latitude_ev": 0.0, "steer_from_spp": 100.0},
        display={"max_cd_m2": 200.0},
    )
    assert "max_spp = 300" in job.to_toml()
    r = aleph.render_job(job)
    assert_matches_exr(r.rgb, r.aovs, exr_channels(tmp_path / "cli.exr"))
    with pytest.raises(aleph.JobError, match="max_sp"):
        aleph.RenderJob(cornell, sampling={"max_sp": 300})
    # Without the table, the same budget is refused: spp above the per-pixel cap.
    with pytest.raises(aleph.JobError, match="max_spp"):
        aleph.render(cornell, spp=5000, resolution=(8, 8))


def test_preview_rewrites_the_png_and_ends_on_time(tmp_path, cornell):
    """preview=True: a still from 2 spp, refined until the time budget (every pixel must
    converge to stop sooner: about 350 spp at this size), its PNG and EXR written."""
    r = aleph.render(
        cornell,
        resolution=(256, 192),
        preview=True,
        time=0.5,
        sampling={"converged_fraction": 1.0},
        output=tmp_path / "p",
    )
    assert (tmp_path / "p.png").is_file() and (tmp_path / "p.exr").is_file()
    assert r.stats[0]["stop"] == "time budget spent"
    assert r.spp.min() >= 2


@pytest.mark.parametrize(
    "kw,words",
    [
        ({"preview": True, "sampler": "uniform"}, "--preview"),
        ({"denoise_quality": "best"}, "denoise_quality"),
        ({"denoise_quality": "fast"}, "nothing is denoised"),
        pytest.param(
            {"denoise": True},
            "--features denoise",
            marks=pytest.mark.skipif(aleph.DENOISER, reason="built with the denoiser"),
        ),
    ],
)
def test_preview_and_denoise_refusals(cornell, kw, words):
    with pytest.raises(aleph.JobError, match=words):
        aleph.RenderJob(cornell, **kw)


def _render_in_worker(scene, queue):
    queue.put(aleph.render(scene, spp=4, resolution=(48, 40), denoise=aleph.DENOISER).rgb)


def test_a_spawned_worker_renders_the_parents_image(cornell):
    """Worker processes are started with "spawn" (docs/python.md: a process forked after its
    parent rendered inherits its thread pools without their threads); one renders what the
    parent does, bit for bit, denoised too in a build with the denoiser."""
    import multiprocessing as mp

    parent = aleph.render(cornell, spp=4, resolution=(48, 40), denoise=aleph.DENOISER)
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    p = ctx.Process(target=_render_in_worker, args=(str(cornell), queue))
    p.start()
    child = queue.get(timeout=120)
    p.join(timeout=60)
    assert p.exitcode == 0
    assert same_bits(child, parent.rgb)
