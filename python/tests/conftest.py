"""Shared fixtures: the repository's scenes and the CLI built from the same sources."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


@pytest.fixture(scope="session")
def cli() -> pathlib.Path:
    """The `aleph` binary: $ALEPH_CLI, else target/release/aleph (built if missing)."""
    if "ALEPH_CLI" in os.environ:
        path = pathlib.Path(os.environ["ALEPH_CLI"])
    else:
        path = ROOT / "target" / "release" / "aleph"
        if not path.exists():
            subprocess.run(
                ["cargo", "build", "--release", "--bin", "aleph"], cwd=ROOT, check=True
            )
    assert path.exists(), f"{path}: no aleph binary"
    return path


@pytest.fixture
def cornell() -> pathlib.Path:
    return SCENES / "cornell-box" / "scene.toml"


@pytest.fixture
def cornell_motion() -> pathlib.Path:
    return SCENES / "cornell-motion" / "scene.toml"
