"""Radiosity against an independent renderer (issue 13): ``lumiwall render`` of the
Cornell box fixture at ``--error 1%`` compared with a stored Mitsuba 3 reference
(``fixtures/scenes/cornell/mitsuba/``, made by ``tests/reference/mitsuba/``) on
16×16-pixel block means of Y over the surfaces (emitter and background excluded, from
the reference alone).

Figures on 2026-12-02: relative L1 5.17 % before the cluster-intensity refinement fix
(back wall above the tall block 10 % dark), 1.66 % after; the reference's own noise is
0.1 % per block. On 2026-12-04: 0.90 % and mean Y 0.9932 with patches sending only from
their leaves; 0.74 % and 0.9963 once the floor under the blocks (inside a closed solid)
stopped dimming the elements that straddle the blocks' feet (issue 13 asks ≤ 1 % at
``--error 1%`` and the mean within 0.5 %).
"""

import pathlib
import subprocess

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "fixtures" / "scenes" / "cornell" / "cornell.toml"
REFERENCE = ROOT / "fixtures" / "scenes" / "cornell" / "mitsuba" / "reference_y.npy"
BLOCK = 16


def read_y(path: pathlib.Path) -> np.ndarray:
    import Imath
    import OpenEXR

    f = OpenEXR.InputFile(str(path))
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    raw = f.channel("Y", Imath.PixelType(Imath.PixelType.FLOAT))
    return np.frombuffer(raw, np.float32).reshape(h, w).astype(np.float64)


def dilate(mask: np.ndarray, steps: int) -> np.ndarray:
    out = mask.copy()
    for _ in range(steps):
        grown = out.copy()
        grown[1:, :] |= out[:-1, :]
        grown[:-1, :] |= out[1:, :]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def block_means(a: np.ndarray, surf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    h, w = a.shape
    shape = (h // BLOCK, BLOCK, w // BLOCK, BLOCK)
    frac = surf.astype(float).reshape(shape).mean((1, 3))
    sums = np.where(surf, a, 0.0).reshape(shape).mean((1, 3))
    return sums / np.maximum(frac, 1e-9), frac >= 0.9


def test_cornell_box_radiosity_is_within_1_percent_of_mitsuba_and_its_mean_within_half_a_percent(tmp_path, lumiwall_bin):
    ref = np.load(REFERENCE).astype(np.float64)
    out = tmp_path / "cornell.exr"
    subprocess.run(
        [str(lumiwall_bin), "render", str(SCENE), "--error", "1%", "--out", str(out)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    y = read_y(out)
    assert y.shape == ref.shape
    surf = ~dilate(ref > 1000.0, 2) & ~dilate(ref <= 0.0, 1)
    rb, used = block_means(ref, surf)
    lb, _ = block_means(y, surf)
    assert used.sum() > 150
    rel_l1 = np.abs(lb[used] - rb[used]).sum() / rb[used].sum()
    ratio = lb[used].sum() / rb[used].sum()
    print(f"relative L1 {100 * rel_l1:.2f} %, mean Y ratio {ratio:.4f}, {used.sum()} blocks")
    assert rel_l1 <= 0.01, f"relative L1 {100 * rel_l1:.2f} %"
    assert abs(ratio - 1.0) <= 0.005, f"mean Y ratio {ratio:.4f}"
