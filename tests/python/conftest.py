"""Shared fixtures of the Python cross-checks."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def lumiwall_bin() -> pathlib.Path:
    """The debug `lumiwall` binary. scripts/test passes the one `cargo test` just built
    (LUMIWALL_BIN): building it again here with `cargo build -p lumiwall` would resolve
    the dependencies' features without the dev-dependencies and recompile a third of
    the workspace. Without it, it is built once per session with the features
    scripts/test builds with (the camera feature)."""
    given = os.environ.get("LUMIWALL_BIN")
    if given:
        path = pathlib.Path(given)
        assert path.is_file(), f"LUMIWALL_BIN={given} is not a file"
        return path
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
