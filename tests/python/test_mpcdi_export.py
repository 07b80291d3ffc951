"""``lumiwall export --format mpcdi`` checked by a reader written from the MPCDI v2.0
standard (``mpcdi_checks.py``): every structural check of
``fixtures/formats/mpcdi-v2.md`` section 7, and the standard's colour pipeline applied
with numpy to the package's LUTs, primaries, alpha and beta maps, compared with
``lumiwall apply`` at 10 bit on the same colours at the same places of each display.

Walls: ``mono-2x1`` commissioned with the virtual camera (flat fields: RGB alpha maps,
colour level 4) and ``dlp-infitec-2x1`` (single-chip DLPs with a white segment, two
eyes: two buffers, colour level 5 with a 3D correction LUT).
"""

import json
import pathlib
import subprocess

import numpy as np
import pytest

import mpcdi_checks

OpenEXR = pytest.importorskip("OpenEXR")
cv2 = pytest.importorskip("cv2")
colour = pytest.importorskip("colour")

ROOT = pathlib.Path(__file__).resolve().parents[2]
BITS = 10
GAMMA = 2.2  # the package's decode: linear = e^2.2 (checked against the decode LUT)
IMAGE = (48, 24)  # test image per display: width, height


def decode_png(data):
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    return image[:, :, ::-1].astype(float) / 65535.0


def commission_and_export(lumiwall, tmp, wall, extra, name=None):
    name = name or wall
    profiles = tmp / name
    subprocess.run(
        [str(lumiwall), "commission", "--meter", "direct", "--noise", "none", "--wall",
         str(ROOT / "fixtures" / "walls" / f"{wall}.toml"), "--out", str(profiles), *extra],
        check=True,
        capture_output=True,
    )
    out = tmp / f"{name}-mpcdi"
    run = subprocess.run(
        [str(lumiwall), "export", "--format", "mpcdi", "--commission", str(profiles),
         "--out-dir", str(out), "--projector-resolution", "1920x1200"],
        check=True,
        capture_output=True,
        text=True,
    )
    print(run.stdout)
    return profiles, out / f"{wall}.mpcdi"


def has_camera(lumiwall):
    help_text = subprocess.run([str(lumiwall), "commission", "--help"], capture_output=True, text=True).stdout
    return "--camera" in help_text


@pytest.fixture(scope="module")
def packages(lumiwall_bin, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mpcdi")
    camera = ["--camera", "virtual"] if has_camera(lumiwall_bin) else []
    return tmp, [
        commission_and_export(lumiwall_bin, tmp, "mono-2x1", camera),
        commission_and_export(lumiwall_bin, tmp, "dlp-infitec-2x1", []),
        # a common black: the beta maps raise each display's black to it
        commission_and_export(lumiwall_bin, tmp, "dlp-infitec-2x1", ["--black", "common"], "dlp-common"),
        commission_and_export(lumiwall_bin, tmp, "mono-2x1", ["--black", "common"], "mono-common"),
    ]


def test_mpcdi_packages_pass_every_structural_check_of_the_v2_standard(packages):
    _, exported = packages
    levels = []
    for _, package in exported:
        errors = mpcdi_checks.validate(package)
        assert errors == [], f"{package.name}: {errors}"
        p = mpcdi_checks.Package(package)
        levels.append(p.root.get("color"))
        buffers = {b.get("id") for b in p.root.find("display")}
        print(f"{package.name}: valid; colour level {levels[-1]}, buffers {sorted(buffers)}")
    assert levels == ["4", "5", "5", "4"], "a white segment needs the 3D correction of level 5"


def test_a_broken_package_is_caught_by_the_checks(packages, tmp_path):
    """The validator is not blind: a package with a misspelt attribute, an orphan file
    and the warp's rows flipped fails the matching checks."""
    _, exported = packages
    original = mpcdi_checks.Package(exported[0][1])
    broken = tmp_path / "broken.mpcdi"
    import zipfile

    with zipfile.ZipFile(broken, "w") as z:
        for name in original.zip.namelist():
            data = original.read(name)
            if name == "mpcdi.xml":
                data = data.replace(b"xSize=", b"xsize=", 1)
            if name.endswith(".pfm"):
                header, rows = data[:-17 * 17 * 12], data[-17 * 17 * 12:]
                flipped = b"".join(rows[i * 17 * 12:(i + 1) * 17 * 12] for i in reversed(range(17)))
                data = header + flipped
            z.writestr(name, data)
        z.writestr("stray.png", b"")
    errors = " ".join(mpcdi_checks.validate(broken))
    for check in ("X6", "Z6 orphans", "P6"):
        assert check in errors, f"{check} not reported: {errors}"


def write_exr(path, xyz):
    rows = xyz.astype(np.float32)
    channels = {c: np.ascontiguousarray(rows[:, :, i]) for i, c in enumerate("XYZ")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))


def post_pass(lumiwall, profile, encoded, tmp):
    """lumiwall apply's 10-bit codes for an image of encoded common-gamut RGB."""
    p = json.loads(profile.read_text())
    white = np.array(p["target_white_xyz_cd_m2"])
    npm = colour.normalised_primary_matrix(np.array(p["common_primaries_xy"]), colour.XYZ_to_xy(white))
    xyz = (encoded ** GAMMA) @ npm.T * white[1]
    exr, png = tmp / f"{profile.stem}.exr", tmp / f"{profile.stem}.png"
    write_exr(exr, xyz)
    subprocess.run(
        [str(lumiwall), "apply", "--profile", str(profile), "--in", str(exr), "--bit-depth",
         str(BITS), "--no-dither", "--out", str(png)],
        check=True,
        capture_output=True,
    )
    bgr = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    return (bgr[:, :, ::-1].astype(np.int64)) >> (16 - BITS)


def test_the_standards_colour_pipeline_on_the_package_reproduces_the_post_pass(lumiwall_bin, packages):
    tmp, exported = packages
    w, h = IMAGE
    raised = 0
    rng = np.random.default_rng(2020)
    u = np.tile((np.arange(w) + 0.5) / w, h)
    v_top = np.repeat((np.arange(h) + 0.5) / h, w)
    for profiles, package in exported:
        p = mpcdi_checks.Package(package)
        if p.root.get("color") == "4":
            _, decode = mpcdi_checks.read_cube(p.read("decode.cube").decode())
            grid = np.linspace(0, 1, len(decode))
            assert np.abs(decode[:, 0] - grid ** GAMMA).max() < 1e-7, "decode is e^2.2"
        for region_id in p.regions:
            raised += decode_png(p.read(p.path_of(region_id, "betaMap"))).max() > 1e-4
            encoded = rng.random((h, w, 3))
            encoded[0, :8] = np.array([[1, 1, 1], [0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1], [0.5, 0.5, 0.5]])
            direct = post_pass(lumiwall_bin, profiles / f"{region_id}.json", encoded, tmp)
            run = mpcdi_checks.region_pipeline(p, region_id, decode_png)
            drive = run(encoded.reshape(-1, 3), u, v_top)
            via = np.rint(np.clip(drive, 0, 1) * (2**BITS - 1)).reshape(h, w, 3)
            diff = np.abs(via - direct).max(axis=2)
            # colours the post pass shows without gamut or range mapping and whose drives
            # a LUT resolves: every drive between 32 and 1022 codes
            resolved = (direct.min(axis=2) >= 32) & (direct.max(axis=2) < 2**BITS - 1)
            within = (diff <= 1).mean()
            print(
                f"{package.name} {region_id}: {100 * within:.1f} % of {w * h} colours within one "
                f"10-bit code, max {diff.max():.0f}; where every drive is in 32..1022 ({100 * resolved.mean():.0f} %): "
                f"max {diff[resolved].max():.0f}"
            )
            worst = np.unravel_index(np.argmax(np.where(resolved, diff, 0)), diff.shape)
            print(f"  worst resolved: input {encoded[worst]}, package {via[worst]}, post pass {direct[worst]}")
            assert resolved.mean() > 0.5
            # where a drive is below 32 codes the post pass's gamut handling at the
            # common gamut's edge (a negative black offset) and the steep dark end
            # differ from a plain clip, as for the .cube export
            if p.root.get("color") == "4":
                # the same arithmetic: LUT and α interpolation only
                assert diff[resolved].max() <= 1 and within > 0.85, region_id
            else:
                # the white-segment step sampled at 33³ bends inside LUT cells
                assert diff[resolved].max() <= 2 and within > 0.85, region_id
            # black itself (pixel 1 of the first row) shows the post pass's black
            assert abs(via[0, 1] - direct[0, 1]).max() <= 1, (region_id, via[0, 1], direct[0, 1])
    assert raised > 0, "a common black should give some display a beta map above 0"
