#!/usr/bin/env python3
"""Issue 17: voxel-based GI (`lumiwall render --method voxel-gi`) on a dynamic scene,
per frame voxelisation and GI time by voxel resolution and the measured error of its
direct + one-bounce image against an independent Mitsuba 3 path trace that stops after
the same bounce (`max_depth` 3: emitted, direct, one indirect reflection), in one table.

The error is the relative L1 of 16×16-pixel block means of Y over the surfaces (as
tests/python/test_radiosity_mitsuba.py measures the radiosity). The keyframe motion
for Mitsuba comes from animation_table.py (implemented there again from the scene
file, independently of lumiwall's).

Usage (repository root, after cargo build --release -p lumiwall; a venv with
`pip install mitsuba numpy openexr`, Debian libllvm19):
  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    VENV/bin/python tests/reference/mitsuba/voxel_gi_table.py \\
    [--scene S] [--frames 0,30,59] [--voxels 64,128,256,512] [--vpls 256] [--spp 512] [--cpu]

A scene without [animation] (e.g. cornell_point.toml, a bare bulb: point lights) is
measured as its one frame.
"""
import argparse
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(HERE))

import test_radiosity_mitsuba as blocks  # noqa: E402
from animation_table import measured, mover  # noqa: E402


def mitsuba_frame(scene, frame, spp, npass):
    """Mean of `npass` Mitsuba passes of the frame, direct + one bounce (Y, cd/m²)."""
    import tomllib

    import mitsuba_ref

    cfg = tomllib.load(open(scene, "rb"))
    sc = mitsuba_ref.build(str(scene), move=mover(cfg, pathlib.Path(scene).parent, frame), max_depth=3)
    return np.mean([mitsuba_ref.render_y(sc, spp, 7000 + 31 * frame + k) for k in range(npass)], 0)


def run_lumiwall(a, frames, voxels, vpls, out):
    """Runs lumiwall on each frame; returns {frame: (voxelize ms, GI ms)} and the
    device line."""
    times, device = {}, "CPU"
    for f in frames:
        cmd = [a.lumiwall, "render", a.scene, "--method", "voxel-gi", "--voxels", str(voxels),
               "--light-samples", str(a.light_samples), "--vpls", str(vpls),
               "--out", str(out)] + (["--cpu"] if a.cpu else [])
        if a.animated:
            cmd += ["--frames", f"{f}..{f}"]
        run = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
        for line in run.stdout.splitlines():
            if line.startswith("voxel GI on"):
                device = line[len("voxel GI on "):]
            m = re.match(r"\s*(\d+|-)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)", line)
            if m:
                times[f] = (float(m.group(2)), float(m.group(6)))
    return times, device


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lumiwall", default=str(ROOT / "target" / "release" / "lumiwall"))
    ap.add_argument("--scene", default=str(ROOT / "fixtures/scenes/cornell/cornell_dynamic.toml"))
    ap.add_argument("--frames", default="0,30,59")
    ap.add_argument("--voxels", default="64,128,256,512")
    ap.add_argument("--vpls", default="256")
    ap.add_argument("--light-samples", type=int, default=256)
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--passes", type=int, default=1)
    ap.add_argument("--cpu", action="store_true")
    a = ap.parse_args()
    import tomllib
    a.animated = "animation" in tomllib.load(open(a.scene, "rb"))
    frames = [int(f) for f in a.frames.split(",")] if a.animated else [0]
    refs = {}
    for f in frames:
        start = time.perf_counter()
        refs[f] = mitsuba_frame(a.scene, f, a.spp, a.passes)
        print(f"Mitsuba frame {f}: {a.spp} spp × {a.passes}, max_depth 3, "
              f"{time.perf_counter() - start:.1f} s", flush=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for vpls in [int(v) for v in a.vpls.split(",")]:
            for n in [int(v) for v in a.voxels.split(",")]:
                out = pathlib.Path(tmp) / f"v{n}.exr"
                times, device = run_lumiwall(a, frames, n, vpls, out)
                name = (lambda f: f"v{n}_{f:04}.exr") if a.animated else (lambda f: f"v{n}.exr")
                errs = [measured(blocks.read_y(pathlib.Path(tmp) / name(f)), refs[f]) for f in frames]
                vox = np.mean([times[f][0] for f in frames])
                gi = np.mean([times[f][1] for f in frames])
                rows.append((n, vpls, vox, gi, errs, device))
    print(f"\nvoxel GI on {rows[0][5]}, {a.light_samples} emitter samples; error against "
          f"Mitsuba (direct + one bounce, {a.spp} spp), "
          + (f"frames {a.frames}" if a.animated else "a still scene"))
    head = " ".join(f"{'frame ' + str(f):>9}" for f in frames)
    print(f"{'voxels':>7} {'VPLs':>5} {'voxelize ms':>11} {'GI ms':>9} {head} {'mean':>7}")
    for n, vpls, vox, gi, errs, _ in rows:
        cells = " ".join(f"{100 * e:>8.2f}%" for e in errs)
        print(f"{n:>6}³ {vpls:>5} {vox:>11.1f} {gi:>9.1f} {cells} {100 * np.mean(errs):>6.2f}%")


if __name__ == "__main__":
    main()
