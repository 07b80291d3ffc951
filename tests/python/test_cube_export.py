"""Cross-check of ``lumiwall export --format cube`` against lumiwall's post pass,
read and applied by colour-science (``colour.read_LUT``), independent of lumiwall's
LUT code.

The small wall is commissioned with the exact meter; each display's .cube is read by
colour-science and applied (trilinear and tetrahedral) to test colours: the primaries,
secondaries, a grey ramp and random colours of the common gamut. The same colours go
through ``lumiwall apply`` as XYZ (computed here by colour-science from the profile's
common primaries and target white, and the .cube's documented encoding), at 10 bit
without dither.

Measured (65³, trilinear and tetrahedral alike): every colour whose drives are all at
least 32 codes agrees within one code; 98 % of all colours do. Where a display channel's
intensity goes to zero inside a LUT cell (the common gamut's edges are the narrowest
display's edges, and the darkest colours fall below a display's black floor) the drive,
about intensity^(1/2.2), and the post pass's gamut handling bend faster than a LUT cell
resolves: up to 51 codes there at 65³, 37 at 129³. The test asserts both figures.
"""

import json
import pathlib
import subprocess

import numpy as np
import pytest

colour = pytest.importorskip("colour")
OpenEXR = pytest.importorskip("OpenEXR")
cv2 = pytest.importorskip("cv2")

ROOT = pathlib.Path(__file__).resolve().parents[2]
WALL = ROOT / "fixtures" / "walls" / "mono-2x1.toml"
GAMMA = 2.2  # the .cube's documented input encoding: linear = e^2.2
BITS = 10
SIZE = 65
# Drives (10-bit codes) from which every channel is resolved by the LUT.
RESOLVED_FROM_CODE = 32
# Share of all test colours within one code (measured 97.7–98.1 %).
WITHIN_ONE_SHARE = 0.97


def sample_colours() -> np.ndarray:
    """Encoded common-gamut RGB in [0, 1]: corners, a grey ramp, random colours."""
    corners = np.array([[r, g, b] for r in (0, 1) for g in (0, 1) for b in (0, 1)], float)
    greys = np.repeat(np.linspace(0.0, 1.0, 101)[:, None], 3, axis=1)
    rng = np.random.default_rng(171)
    return np.vstack([corners, greys, rng.random((2000, 3))])


def write_xyz_exr(path: pathlib.Path, xyz: np.ndarray) -> None:
    """One row of pixels, channels X, Y, Z (float32)."""
    row = xyz.astype(np.float32)[None, :, :]
    channels = {c: np.ascontiguousarray(row[:, :, i]) for i, c in enumerate("XYZ")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


def common_gamut_xyz(profile: dict, encoded: np.ndarray) -> np.ndarray:
    """XYZ in cd/m² of encoded common-gamut RGB (1, 1, 1 = the target white)."""
    white = np.array(profile["target_white_xyz_cd_m2"])
    npm = colour.normalised_primary_matrix(
        np.array(profile["common_primaries_xy"]), colour.XYZ_to_xy(white)
    )
    return (encoded**GAMMA) @ npm.T * white[1]


def post_pass_codes(lumiwall: pathlib.Path, profile: pathlib.Path, exr, png) -> np.ndarray:
    subprocess.run(
        [str(lumiwall), "apply", "--profile", str(profile), "--in", str(exr),
         "--bit-depth", str(BITS), "--no-dither", "--out", str(png)],
        check=True,
        capture_output=True,
    )
    bgr = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    return (bgr[0, :, ::-1].astype(np.int64)) >> (16 - BITS)


@pytest.fixture(scope="module")
def exported(lumiwall_bin, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cube")
    profiles = tmp / "profiles"
    subprocess.run(
        [str(lumiwall_bin), "commission", "--meter", "direct", "--noise", "none",
         "--wall", str(WALL), "--out", str(profiles)],
        check=True,
        capture_output=True,
    )
    out = tmp / "cube"
    subprocess.run(
        [str(lumiwall_bin), "export", "--format", "cube", "--commission", str(profiles),
         "--out-dir", str(out), "--cube-size", str(SIZE)],
        check=True,
        capture_output=True,
    )
    return tmp, profiles, out


@pytest.mark.parametrize("interpolator", ["trilinear", "tetrahedral"])
def test_cube_read_by_colour_science_matches_the_post_pass_within_one_10bit_code_above_code_32(
    lumiwall_bin, exported, interpolator
):
    tmp, profiles, out = exported
    names = sorted(p.name for p in profiles.glob("d*.json"))
    assert names, "the commissioning wrote no profiles"
    encoded = sample_colours()
    table = {
        "trilinear": colour.algebra.table_interpolation_trilinear,
        "tetrahedral": colour.algebra.table_interpolation_tetrahedral,
    }[interpolator]
    for name in names:
        profile = json.loads((profiles / name).read_text())
        # the .cube holds the display centre; a flat field would make the image differ
        assert profile["flat_field"] is None
        lut = colour.read_LUT(str(out / name.replace(".json", ".cube")))
        assert isinstance(lut, colour.LUT3D) and lut.size == SIZE
        via_cube = np.rint(lut.apply(encoded, interpolator=table) * (2**BITS - 1))
        exr = tmp / f"{name}.exr"
        write_xyz_exr(exr, common_gamut_xyz(profile, encoded))
        direct = post_pass_codes(lumiwall_bin, profiles / name, exr, tmp / f"{name}.png")
        diff = np.abs(via_cube - direct).max(axis=1)
        resolved = direct.min(axis=1) >= RESOLVED_FROM_CODE
        within = (diff <= 1).mean()
        worst = int(np.argmax(diff))
        print(
            f"{name} {interpolator}: {100 * within:.2f} % of {len(encoded)} colours within one "
            f"10-bit code; max |Δcode| {diff[resolved].max():.0f} where every drive ≥ "
            f"{RESOLVED_FROM_CODE}, {diff.max():.0f} overall (input {encoded[worst]}, cube "
            f"{via_cube[worst]}, post pass {direct[worst]})"
        )
        assert resolved.mean() > 0.8, "most test colours should be well inside every channel"
        assert diff[resolved].max() <= 1, f"{name}: {diff[resolved].max()} codes apart"
        assert within >= WITHIN_ONE_SHARE, f"{name}: only {within:.3f} within one code"
        assert (direct.max(axis=0) > 512).all(), "the test colours should reach the upper half of every channel"
