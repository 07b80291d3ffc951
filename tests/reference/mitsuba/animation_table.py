#!/usr/bin/env python3
"""Issue 16, item 4: an animation solved as one sequence (Hahn's simultaneous
progressive refinement) against every frame solved on its own, both measured against
an independent Mitsuba 3 path-traced image of that frame, in one table.

Runs `lumiwall render SCENE --frames A..B --per-frame` (which times both), renders
Mitsuba references of every `--every`-th frame, and prints per frame: the sequence's
and the single solve's estimated error, the single solve's time, and both measured
errors (relative L1 of 16×16-pixel block means of Y over the surfaces, as
tests/python/test_radiosity_mitsuba.py measures the still Cornell box).

The keyframe motion is implemented here again from the scene file (linear
translation and angle, rotation about `axis` through `pivot` or the object's
bounding-box centre, held outside the keys), independently of lumiwall's.

Usage (repository root, after cargo build --release -p lumiwall; a venv with
`pip install mitsuba numpy openexr`, Debian libllvm19):
  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    VENV/bin/python tests/reference/mitsuba/animation_table.py \\
    [--scene fixtures/scenes/cornell/cornell_animated.toml] [--frames 0..59] \\
    [--error 1%] [--every 6] [--spp 256]
"""
import argparse
import pathlib
import re
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(HERE))

import test_radiosity_mitsuba as blocks  # noqa: E402


def rotation(axis, deg):
    """Rodrigues: the rotation matrix about the unit `axis` by `deg` degrees."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    t = np.radians(deg)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def pose(keys, frame):
    """(translation, angle) at `frame`, linear between keys, held outside them."""
    ks = sorted(keys, key=lambda k: k["frame"])
    tr = lambda k: np.asarray(k.get("translate", [0, 0, 0]), float)
    ang = lambda k: float(k.get("rotate_deg", 0.0))
    if frame <= ks[0]["frame"]:
        return tr(ks[0]), ang(ks[0])
    for a, b in zip(ks, ks[1:]):
        if frame <= b["frame"]:
            s = (frame - a["frame"]) / (b["frame"] - a["frame"])
            return tr(a) + s * (tr(b) - tr(a)), ang(a) + s * (ang(b) - ang(a))
    return tr(ks[-1]), ang(ks[-1])


def obj_vertices(cfg, fix):
    """Vertices (file units) of every OBJ object."""
    objs, name, allv = {}, None, []
    for line in open(fix / cfg["geometry"]):
        t = line.split()
        if not t:
            continue
        if t[0] == "o":
            name = t[1]
            objs.setdefault(name, [])
        elif t[0] == "v":
            allv.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            objs[name] += [allv[int(i.split("/")[0]) - 1] for i in t[1:]]
    return objs


def mover(cfg, fix, frame):
    """A function (object, vertex in file units) -> moved vertex at `frame`."""
    objs = obj_vertices(cfg, fix)
    motions = {}
    for tr in cfg.get("animation", {}).get("tracks", []):
        if "object" not in tr:
            raise SystemExit("a moving [[lights]] entry: mitsuba_ref.py builds area emitters only")
        obj = tr["object"]
        v = np.asarray(objs[obj])
        pivot = np.asarray(tr.get("pivot", (v.min(0) + v.max(0)) / 2), float)
        t, deg = pose(tr["keys"], frame)
        r = rotation(tr.get("axis", [0, 1, 0]), deg)
        motions[obj] = (pivot, r, t)

    def move(obj, p):
        if obj not in motions:
            return p
        pivot, r, t = motions[obj]
        return list(pivot + r @ (np.asarray(p) - pivot) + t)

    return move


def mitsuba_frame(scene, frame, spp, npass):
    """Mean of `npass` Mitsuba passes of the frame (Y, cd/m²)."""
    import mitsuba_ref

    cfg = tomllib.load(open(scene, "rb"))
    sc = mitsuba_ref.build(str(scene), move=mover(cfg, pathlib.Path(scene).parent, frame))
    return np.mean([mitsuba_ref.render_y(sc, spp, 9000 + 31 * frame + k) for k in range(npass)], 0)


def measured(y, ref):
    surf = ~blocks.dilate(ref > 1000.0, 2) & ~blocks.dilate(ref <= 0.0, 1)
    rb, used = blocks.block_means(ref, surf)
    lb, _ = blocks.block_means(y, surf)
    return np.abs(lb[used] - rb[used]).sum() / rb[used].sum()


def run_lumiwall(binary, scene, frames, error, out):
    cmd = [str(binary), "render", str(scene), "--frames", frames, "--error", error,
           "--per-frame", "--out", str(out)]
    print("$", " ".join(cmd), flush=True)
    run = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    rows, summary = {}, []
    for line in run.stdout.splitlines():
        m = re.match(r"\s*(\d+)\s+[\d.]+\s+([\d.]+)%\s+([\d.]+)%\s+([\d.]+)\s+\d+\s+([\d.]+)%", line)
        if m:
            f = int(m.group(1))
            rows[f] = dict(seq_est=float(m.group(2)), alone_est=float(m.group(3)),
                           alone_s=float(m.group(4)))
        elif line.startswith(("sequence:", "cost:")):
            summary.append(line)
    return rows, summary


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lumiwall", default=str(ROOT / "target" / "release" / "lumiwall"))
    ap.add_argument("--scene", default=str(ROOT / "fixtures/scenes/cornell/cornell_animated.toml"))
    ap.add_argument("--frames", default="0..59")
    ap.add_argument("--error", default="1%")
    ap.add_argument("--every", type=int, default=6, help="Mitsuba reference of every n-th frame")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--passes", type=int, default=1)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "anim.exr"
        rows, summary = run_lumiwall(a.lumiwall, a.scene, a.frames, a.error, out)
        print("\n".join(summary), flush=True)
        first, last = (int(x) for x in a.frames.split(".."))
        checked = [f for f in range(first, last + 1) if (f - first) % a.every == 0 or f == last]
        print(f"\n{'frame':>5} {'seq est':>8} {'alone est':>9} {'alone s':>8} {'Mitsuba s':>9} "
              f"{'seq measured':>12} {'alone measured':>14}")
        seq_l1, alone_l1 = [], []
        for f in checked:
            start = time.perf_counter()
            ref = mitsuba_frame(a.scene, f, a.spp, a.passes)
            mi_s = time.perf_counter() - start
            ys = blocks.read_y(pathlib.Path(tmp) / f"anim_{f:04}.exr")
            ya = blocks.read_y(pathlib.Path(tmp) / f"anim_alone_{f:04}.exr")
            s_l1, a_l1 = measured(ys, ref), measured(ya, ref)
            seq_l1.append(s_l1)
            alone_l1.append(a_l1)
            r = rows[f]
            print(f"{f:>5} {r['seq_est']:>7.2f}% {r['alone_est']:>8.2f}% {r['alone_s']:>8.2f} "
                  f"{mi_s:>9.1f} {100 * s_l1:>11.2f}% {100 * a_l1:>13.2f}%", flush=True)
        print(f"\nmeasured error over {len(checked)} frames, sequence / alone: mean "
              f"{100 * np.mean(seq_l1):.2f} / {100 * np.mean(alone_l1):.2f} %, max "
              f"{100 * max(seq_l1):.2f} / {100 * max(alone_l1):.2f} % (Mitsuba {a.spp} spp × {a.passes})")


if __name__ == "__main__":
    main()
