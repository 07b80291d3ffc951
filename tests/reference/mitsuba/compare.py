#!/usr/bin/env python3
"""Compare lumiwall EXR(s) with Mitsuba passes. Usage: compare.py REF.npy LW.exr [LW.exr...]
Relative L1 of Y on 16x16 block means over surface pixels (emitter and background excluded),
mean Y ratio, region ratios; writes PNGs (ref, lumiwall, ratio) next to the EXR."""
import sys, numpy as np
import OpenEXR, Imath
from PIL import Image

def read_y(path):
    f = OpenEXR.InputFile(path)
    dw = f.header()['dataWindow']; w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    return np.frombuffer(f.channel('Y', Imath.PixelType(Imath.PixelType.FLOAT)), np.float32).reshape(h, w).astype(np.float64)

passes = np.load(sys.argv[1]).astype(np.float64)
ref = passes.mean(0); H, W = ref.shape; B = 16
def blocks(a): return a.reshape(H // B, B, W // B, B).mean((1, 3))
# surface mask: not the emitter (Y > 5000) and not background (Y == 0) in the reference
# emitter: pixels of either image above 1000 cd/m² (surfaces here are < 300), dilated by 2 px
from scipy.ndimage import binary_dilation
lw0 = read_y(sys.argv[2])
emit = binary_dilation((ref > 1000) | (lw0 > 1000), iterations=2)
# background/edge: any pixel where either image is 0, dilated by 1 px
bg = binary_dilation((ref <= 0) | (lw0 <= 0), iterations=1)
surf = ~emit & ~bg
# a block counts only if every pixel sees a surface
frac = blocks(surf.astype(float))
bmask = frac >= 0.9
def blocks_s(a): return blocks(np.where(surf, a, 0.0)) / np.maximum(frac, 1e-9)
rb = blocks_s(ref)
# Mitsuba noise on block means: std error of the mean of passes
n = len(passes)
if n > 1:
    pb = np.stack([blocks_s(p) for p in passes])
    se = pb.std(0, ddof=1) / np.sqrt(n)
    print(f"mitsuba: {n} passes; rel. std err of block means, mean over blocks {np.mean(se[bmask]/rb[bmask])*100:.3f} %")
print(f"emitter pixels (ref) mean Y: {ref[ref >= 9999].mean():.0f}; blocks used {bmask.sum()}/{bmask.size}")
# regions in block coordinates (rows, cols) from the geometry projected with the camera
def proj(p):
    cam = np.array([278.0, 273.0, -800.0]); t = np.tan(np.radians(39.3) / 2)
    d = np.array(p) - cam
    x = -d[0] / d[2] / t; y = d[1] / d[2] / t   # right = -x world (camera looks +z, up +y)
    return (x + 1) / 2 * W, (1 - y) / 2 * H
def save(a, path, lo=None, hi=None):
    lo = a.min() if lo is None else lo; hi = a.max() if hi is None else hi
    Image.fromarray((np.clip((a - lo) / (hi - lo), 0, 1) * 255).astype(np.uint8)).resize((W * 2, H * 2), Image.NEAREST).save(path)
save(np.clip(ref, 0, 300) ** 0.5, sys.argv[1].replace('.npy', '.png'))
# regions: back wall above tall block (z=559.2, x 300..480, y 340..440 mm) and tall block front face
# (quad 265,296 -> 423,247, y 0..330)
def region_mask(poly3d):
    from matplotlib.path import Path
    pts = np.array([proj(p) for p in poly3d])
    yy, xx = np.mgrid[0:H, 0:W]
    return Path(pts).contains_points(np.c_[xx.ravel() + .5, yy.ravel() + .5]).reshape(H, W)
try:
    back = region_mask([[480, 340, 559.2], [300, 340, 559.2], [300, 440, 559.2], [480, 440, 559.2]])
    front = region_mask([[265, 10, 296], [423, 10, 247], [423, 320, 247], [265, 320, 296]])
except ImportError:
    back = front = None
for path in sys.argv[2:]:
    lw = read_y(path)
    if lw.shape != ref.shape:
        lw = np.fliplr(lw) if False else lw
    lb = blocks_s(lw)
    l1 = np.abs(lb - rb)[bmask].sum() / rb[bmask].sum()
    l1pix = np.abs(lw - ref)[surf].sum() / ref[surf].sum()
    ratio = lb[bmask].mean() / rb[bmask].mean()
    print(f"{path}: rel L1 blocks {l1*100:.2f} %, pixels {l1pix*100:.2f} %, mean Y ratio (blocks) {ratio:.4f}, "
          f"emitter px {lw[ref >= 9999].mean():.0f}")
    rpix = np.where(surf, lw / np.maximum(ref, 1e-9), 1.0)
    rblk = np.where(bmask, lb / np.maximum(rb, 1e-9), 1.0)
    print("  block ratio min/max %.3f / %.3f; worst blocks (row,col,ratio):" % (rblk[bmask].min(), rblk[bmask].max()),
          [(int(i), int(j), round(float(rblk[i, j]), 3)) for i, j in zip(*np.unravel_index(np.argsort(-np.abs(rblk - 1), axis=None)[:6], rblk.shape))])
    if back is not None:
        for nm, m in (("back wall above tall block", back), ("tall block front face", front)):
            mm = m & surf
            print(f"  {nm}: {mm.sum()} px, sum ratio {lw[mm].sum()/ref[mm].sum():.3f}, "
                  f"pixel ratio p10/p50/p90 {np.percentile(rpix[mm],10):.3f}/{np.percentile(rpix[mm],50):.3f}/{np.percentile(rpix[mm],90):.3f}")
    save(np.clip(lw, 0, 300) ** 0.5, path.replace('.exr', '.Y.png'))
    save(rpix, path.replace('.exr', '.ratio.png'), 0.8, 1.2)
    save(np.kron(rblk, np.ones((B, B))), path.replace('.exr', '.blockratio.png'), 0.8, 1.2)
    np.set_printoptions(linewidth=200)
    print(np.round(rblk, 2))
