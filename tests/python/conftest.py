"""Shared fixtures of the Python cross-checks."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def lumiwall_bin() -> pathlib.Path:
    """The debug `lumiwall` binary, built once per session with the features
    scripts/test built with (the camera feature), so it is not rebuilt without them."""
    features = os.environ.get("LUMIWALL_CARGO_FEATURES", "")
    extra = ["--features", features] if features else []
    subprocess.run(["cargo", "build", "-q", "-p", "lumiwall", *extra], cwd=ROOT, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    return pathlib.Path(json.loads(meta.stdout)["target_directory"]) / "debug" / "lumiwall"
