#!/usr/bin/env python3
"""Side by side in one run (issue 13, item 5): time for `lumiwall render` and for
Mitsuba 3 (one view, path tracer) to reach a measured error on the Cornell box, both
measured against the stored converged reference (fixtures/scenes/cornell/mitsuba/,
4 × 1024 spp) on 16×16-pixel block means of Y, as tests/python/test_radiosity_mitsuba.py
measures it.

Usage (repository root, after cargo build --release -p lumiwall; a venv with
`pip install mitsuba numpy openexr`, Debian libllvm19):
  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    VENV/bin/python tests/reference/mitsuba/speed_table.py [--lumiwall target/release/lumiwall]

Mitsuba's passes use seeds other than the reference's; its first render (JIT
compilation) is a warm-up and not timed. lumiwall's time is the whole process (scene
load, solve, image). The solution is view-independent: a further view costs one
rasterisation of the solved patches (printed), where Mitsuba renders again.
"""
import argparse
import pathlib
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

SCENE = ROOT / "fixtures" / "scenes" / "cornell" / "cornell.toml"
ERRORS = [0.05, 0.02, 0.01]


def measured_error(y, ref, surf):
    rb, used = blocks.block_means(ref, surf)
    lb, _ = blocks.block_means(y, surf)
    l1 = np.abs(lb[used] - rb[used]).sum() / rb[used].sum()
    return l1, lb[used].sum() / rb[used].sum()


def lumiwall_runs(binary, targets, ref, surf):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for t in targets:
            out = pathlib.Path(tmp) / "frame.exr"
            start = time.perf_counter()
            run = subprocess.run([str(binary), "render", str(SCENE), "--error", f"{100 * t:g}%",
                                  "--out", str(out)], cwd=ROOT, check=True, capture_output=True,
                                 text=True)
            wall = time.perf_counter() - start
            stop = [line for line in run.stdout.splitlines() if line.startswith("stop:")][-1]
            mib = float(stop.split("~")[1].split(" MiB")[0])
            curve = (out.parent / "frame.curve.csv").read_text().strip().splitlines()[-1]
            estimate = float(curve.split(",")[2])
            l1, ratio = measured_error(blocks.read_y(out), ref, surf)
            rows.append(("lumiwall", f"--error {100 * t:g}%", wall, estimate, l1, ratio, mib))
            print(f"lumiwall --error {100 * t:g}%: {wall:.2f} s, estimate {100 * estimate:.2f} %, "
                  f"measured {100 * l1:.2f} %, mean Y {ratio:.4f}, ~{mib:.0f} MiB", flush=True)
    return rows


def mitsuba_runs(spps, ref, surf):
    import mitsuba_ref

    sc = mitsuba_ref.build(str(SCENE))
    mitsuba_ref.render_y(sc, 1, 7)  # JIT warm-up, not timed
    rows = []
    for spp in spps:
        start = time.perf_counter()
        y = mitsuba_ref.render_y(sc, spp, 5000 + spp)
        wall = time.perf_counter() - start
        l1, ratio = measured_error(y, ref, surf)
        rows.append(("Mitsuba", f"{spp} spp", wall, None, l1, ratio, None))
        print(f"Mitsuba {spp} spp: {wall:.2f} s, measured {100 * l1:.2f} %, mean Y {ratio:.4f}",
              flush=True)
    return rows


def time_to(rows, who, err):
    """Shortest time of `who`'s runs whose measured error is at most `err`."""
    times = [r[2] for r in rows if r[0] == who and r[4] <= err]
    return min(times) if times else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lumiwall", default=str(ROOT / "target" / "release" / "lumiwall"))
    ap.add_argument("--targets", default="10,5,2,1", help="lumiwall --error values in %%")
    ap.add_argument("--spp", default="4,16,64,256,1024")
    a = ap.parse_args()
    ref = np.load(blocks.REFERENCE).astype(np.float64)
    surf = ~blocks.dilate(ref > 1000.0, 2) & ~blocks.dilate(ref <= 0.0, 1)
    rows = lumiwall_runs(a.lumiwall, [float(t) / 100 for t in a.targets.split(",")], ref, surf)
    rows += mitsuba_runs([int(s) for s in a.spp.split(",")], ref, surf)
    print()
    print(f"{'run':<10} {'setting':<14} {'time_s':>8} {'estimate':>9} {'measured':>9} {'mean Y':>7} {'MiB':>6}")
    for who, setting, wall, est, l1, ratio, mib in rows:
        est_s = f"{100 * est:.2f}%" if est is not None else "-"
        mib_s = f"{mib:.0f}" if mib is not None else "-"
        print(f"{who:<10} {setting:<14} {wall:>8.2f} {est_s:>9} {100 * l1:>8.2f}% {ratio:>7.4f} {mib_s:>6}")
    print()
    print(f"{'measured error':<15} {'lumiwall s':>11} {'Mitsuba s':>10} {'lumiwall/Mitsuba':>17}")
    for err in ERRORS:
        lw, mi_t = time_to(rows, "lumiwall", err), time_to(rows, "Mitsuba", err)
        ratio = f"{lw / mi_t:.2f}" if lw and mi_t else "-"
        fmt = lambda v: f"{v:.2f}" if v is not None else "not reached"
        print(f"{f'≤ {100 * err:g} %':<15} {fmt(lw):>11} {fmt(mi_t):>10} {ratio:>17}")
    bounded = all(r[4] <= r[3] for r in rows if r[0] == "lumiwall")
    print(f"\nlumiwall's estimate bounds the measured error at every target: {'yes' if bounded else 'NO'}")


if __name__ == "__main__":
    main()
