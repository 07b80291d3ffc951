"""An MPCDI v2.0 reader and structural validator written from the standard, not from
lumiwall's exporter: the checklist of ``fixtures/formats/mpcdi-v2.md`` section 7 (its
check names, Z1…L1, in the messages), and the standard's colour pipeline
``encode(α·(1 − β)·correct(decode(e)) + β)`` (§2.5, Table 2-2) applied with numpy.

A colour level is an upper bound on what a region carries (Table 3-3), so a level-5
package may keep a 1D encode LUT.
"""

import datetime
import math
import re
import struct
import zipfile
import zlib
import xml.etree.ElementTree as ET

import numpy as np

DECLARATION = b'<?xml version="1.0" encoding="utf-8"?>'


class Package:
    """An opened ``.mpcdi``: the zip, the parsed ``mpcdi.xml`` and its regions."""

    def __init__(self, path):
        self.path = str(path)
        self.zip = zipfile.ZipFile(self.path)
        self.raw_xml = self.zip.read("mpcdi.xml")
        self.root = ET.fromstring(self.raw_xml)
        self.regions = {
            r.get("id"): (b.get("id"), r)
            for b in self.root.find("display")
            for r in b
        }
        self.filesets = {fs.get("region"): fs for fs in self.root.find("files")}

    def read(self, name):
        return self.zip.read(name)

    def path_of(self, region, tag):
        element = self.filesets[region].find(tag)
        return None if element is None else element.findtext("path")


def validate(path) -> list:
    """Every violation of the checklist, one string each (empty: valid)."""
    errors = []
    p = Package(path)
    _check_archive(p, errors)
    _check_root(p, errors)
    for region_id, (_, region) in p.regions.items():
        _check_region(p, region, errors)
        if region_id not in p.filesets:
            errors.append(f"X10 no fileset for {region_id}")
            continue
        _check_fileset(p, region, p.filesets[region_id], errors)
    _check_references(p, errors)
    return errors


def _check_archive(p, errors):
    if not p.path.endswith(".mpcdi"):
        errors.append("Z1 extension")
    if p.zip.testzip() is not None:
        errors.append("Z1 crc")
    names = p.zip.namelist()
    if names.count("mpcdi.xml") != 1:
        errors.append("Z2 mpcdi.xml")
    if any("/" in n or "\\" in n for n in names) or len(set(names)) != len(names):
        errors.append("Z3 folders or duplicates")
    if sum(n.lower().endswith(".xml") for n in names) != 1:
        errors.append("Z4 one xml")
    if any(i.compress_type not in (0, 8) for i in p.zip.infolist()):
        errors.append("Z5 compression")


def _check_root(p, errors):
    if not p.raw_xml.startswith(DECLARATION):
        errors.append("X1 declaration")
    a = p.root.attrib
    if p.root.tag != "MPCDI":
        errors.append("X1 root")
    if a.get("profile") not in ("2d", "3d", "a3", "sl"):
        errors.append("X2 profile")
    if a.get("geometry") not in ("1", "2") or a.get("color") not in list("12345"):
        errors.append("X2 levels")
    if a.get("version") != "2.0" or "level" in a:
        errors.append("X2 version")
    date = a.get("date", "")
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2}", date):
        errors.append("X2 date")
    else:
        datetime.datetime.strptime(date, "%Y-%m-%d %H:%M:%S")
    tags = [c.tag for c in p.root]
    if tags not in (["display", "files"], ["display", "files", "extensionSet"]):
        errors.append(f"X3 {tags}")
    for b in p.root.find("display"):
        if b.tag != "buffer" or len(b) == 0:
            errors.append("X4 buffer")
        if set(b.attrib) - {"id", "xResolution", "yResolution"}:
            errors.append(f"X5 {sorted(b.attrib)}")
        if any(int(b.get(k)) <= 0 for k in ("xResolution", "yResolution") if k in b.attrib):
            errors.append("X5 resolution")
    if len(p.regions) != sum(len(b) for b in p.root.find("display")):
        errors.append("X4 region ids not unique")


def _check_region(p, r, errors):
    need = {"id", "x", "y", "xSize", "ySize", "xResolution", "yResolution"}
    if set(r.attrib) != need:
        errors.append(f"X6 {sorted(r.attrib)}")
        return
    x, y, xs, ys = (float(r.get(k)) for k in ("x", "y", "xSize", "ySize"))
    if not (xs > 0 and ys > 0 and x >= 0 and y >= 0 and x + xs <= 1 + 1e-6 and y + ys <= 1 + 1e-6):
        errors.append("X6 rectangle")
    if [c.tag for c in r] != ["color"]:
        errors.append(f"X7 {[c.tag for c in r]}")
        return
    _check_color(p, r.find("color"), errors)


def _check_color(p, c, errors):
    level = int(p.root.get("color"))
    tags = [e.tag for e in c]
    if tags not in (["decode", "encode"], ["decode", "correct", "encode"]):
        errors.append(f"X9 {tags}")
        return
    decode, encode = c.find("decode").get("type"), c.find("encode").get("type")
    correct = c.find("correct")
    correct_type = "none" if correct is None else correct.get("type")
    allowed = {  # level: decode, correct, encode types (upper bounds, Table 3-3)
        1: ({"gamma", "none"}, {"none"}, {"gamma", "none"}),
        2: ({"gamma", "none"}, {"none"}, {"gamma", "none"}),
        3: ({"lut1d"}, {"lut1d-primary"}, {"lut1d"}),
        4: ({"lut1d"}, {"lut1d-primary"}, {"lut1d"}),
        5: ({"lut1d"}, {"lut1d-primary", "lut3d"}, {"lut1d", "lut3d"}),
    }[level]
    if decode not in allowed[0] or correct_type not in allowed[1] or encode not in allowed[2]:
        errors.append(f"X9 level {level}: {decode} {correct_type} {encode}")
    if correct_type == "lut1d-primary":
        rows = correct.find("primaries")
        if rows is None or [q.tag for q in rows] != ["redPrimary", "greenPrimary", "bluePrimary"]:
            errors.append("X9 primaries")
        else:
            for row in rows:
                if [q.tag for q in row] != ["red", "green", "blue"]:
                    errors.append("X9 primary row")
                [float(q.text) for q in row]


def _check_fileset(p, region, fs, errors):
    level = int(p.root.get("color"))
    for fe in fs:
        paths = fe.findall("path")
        if len(paths) != 1 or not paths[0].text or paths[0].text != paths[0].text.strip():
            errors.append(f"X11 {fe.tag}")
    warp = fs.find("geometryWarpFile")
    if warp is None or warp.findtext("interpolation") not in ("linear", "keystone", "smooth", "unknown"):
        errors.append("X12 geometryWarpFile")
    else:
        _check_pfm(p.read(warp.findtext("path")), region, errors)
    for tag, needed in (("alphaMap", True), ("betaMap", level >= 3)):
        m = fs.find(tag)
        if m is None:
            if needed:
                errors.append(f"X13/X14 {tag} missing")
            continue
        depth = m.findtext("componentDepth")
        if depth != ("1" if level <= 3 else "3") or m.findtext("bitDepth") not in ("8", "16"):
            errors.append(f"X15 {tag} depths")
        if tag == "alphaMap" and not float(m.findtext("gammaEmbedded")) > 0:
            errors.append("X13 gammaEmbedded")
        _check_png(p.read(m.findtext("path")), depth, m.findtext("bitDepth"), errors)
    color = region.find("color")
    correct = color.find("correct")
    correct_type = "none" if correct is None else correct.get("type")
    for tag, kind in (
        ("decodeLUT", color.find("decode").get("type")),
        ("correctLUT", correct_type),
        ("encodeLUT", color.find("encode").get("type")),
    ):
        e = fs.find(tag)
        wanted = kind in ("lut1d", "lut1d-primary", "lut3d")
        if (e is not None) != wanted:
            errors.append(f"X17 {tag}")
        elif e is not None:
            if e.findtext("interpolation") not in ("linear", "smooth", "unknown"):
                errors.append(f"X17 {tag} interpolation")
            size, _ = read_cube(p.read(e.findtext("path")).decode())
            if (kind == "lut3d") != (size[0] == 3):
                errors.append(f"L1 {tag} is {size[0]}D for {kind}")


def _check_pfm(data, region, errors):
    m = re.match(rb"PF\s(\d+)\s(\d+)\s(-?[0-9.eE+-]+)\s", data)
    if not m:
        errors.append("P1 header")
        return
    w, h, scale = int(m.group(1)), int(m.group(2)), float(m.group(3))
    if not scale < 0 or len(data) - m.end() != w * h * 12:
        errors.append("P1/P2 scale or length")
        return
    if not (2 <= w <= 32 and 2 <= h <= 32):
        errors.append("P3 grid")
    values = np.frombuffer(data[m.end():], "<f4").reshape(h, w, 3)
    u, v = values[..., 0], values[..., 1]
    if None not in (region.get(k) for k in ("x", "y", "xSize", "ySize")):  # else X6
        x, y, xs, ys = (float(region.get(k)) for k in ("x", "y", "xSize", "ySize"))
        if np.isnan(u).any() or not ((u >= x - 1e-6) & (u <= x + xs + 1e-6)).all():
            errors.append("P4 u outside the region")
        if not ((v >= y - 1e-6) & (v <= y + ys + 1e-6)).all():
            errors.append("P4 v outside the region")
    # P6: netpbm order, the row stored last is the top: v grows with the stored row
    if not (np.diff(v[:, 0]) > 0).all():
        errors.append("P6 row order")


def png_chunks(data):
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, chunks = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise ValueError(f"CRC of {kind}")
        chunks.append((kind, body))
        pos += 12 + length
    return chunks


def _check_png(data, depth, bits, errors):
    try:
        chunks = png_chunks(data)
    except ValueError as e:
        errors.append(f"G1 {e}")
        return
    if chunks[0][0] != b"IHDR":
        errors.append("G1 IHDR")
        return
    w, h, bd, ct, _, _, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
    if interlace or ct != {"1": 0, "3": 2}[depth] or str(bd) != bits:
        errors.append("G1/G2 PNG type")
    if any(k in (b"gAMA", b"sRGB", b"iCCP", b"cHRM", b"PLTE", b"tRNS") for k, _ in chunks):
        errors.append("G2 colour chunks")
    if w < 2 or h < 2:
        errors.append("G3 size")


def _check_references(p, errors):
    refs = {fe.findtext("path") for fs in p.filesets.values() for fe in fs}
    ext = p.root.find("extensionSet")
    if ext is not None:
        names = set()
        for e in ext:
            name = e.get("name", e.get("Name"))
            if e.tag != "extension" or not name or name in names:
                errors.append("X18 extension")
            names.add(name)
            if (e.get("hasExternalFiles") or "").lower() not in ("true", "false"):
                errors.append("X18 hasExternalFiles")
            refs |= {f.text.strip() for f in e.iter("file")}
    names = set(p.zip.namelist())
    if names - refs - {"mpcdi.xml"}:
        errors.append(f"Z6 orphans {sorted(names - refs - {'mpcdi.xml'})}")
    if refs - names:
        errors.append(f"Z6 missing {sorted(refs - names)}")


def read_cube(text):
    """((dimension, size), table): a 1D table (size, 3) or a 3D one (size³, 3), red
    fastest, as the .cube format stores it."""
    size = None
    rows = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#") or line.startswith("TITLE") or line.startswith("DOMAIN"):
            continue
        if line.startswith("LUT_1D_SIZE"):
            size = (1, int(line.split()[1]))
        elif line.startswith("LUT_3D_SIZE"):
            size = (3, int(line.split()[1]))
        else:
            rows.append([float(v) for v in line.split()])
    table = np.array(rows)
    expected = size[1] if size[0] == 1 else size[1] ** 3
    if table.shape != (expected, 3):
        raise ValueError(f"L1 {table.shape} for {size}")
    return size, table


def apply_1d(table, x):
    grid = np.linspace(0.0, 1.0, len(table))
    return np.stack([np.interp(x[:, c], grid, table[:, c]) for c in range(3)], axis=1)


def apply_3d(table, n, x):
    """Trilinear interpolation in an n³ table stored red fastest."""
    t = np.clip(x, 0.0, 1.0) * (n - 1)
    i0 = np.minimum(np.floor(t).astype(int), n - 2)
    f = t - i0
    out = np.zeros_like(x)
    for dr in (0, 1):
        for dg in (0, 1):
            for db in (0, 1):
                w = (
                    (f[:, 0] if dr else 1 - f[:, 0])
                    * (f[:, 1] if dg else 1 - f[:, 1])
                    * (f[:, 2] if db else 1 - f[:, 2])
                )
                idx = (i0[:, 0] + dr) + (i0[:, 1] + dg) * n + (i0[:, 2] + db) * n * n
                out += w[:, None] * table[idx]
    return out


def sample_map(image, u, v_top):
    """Bilinear sample of a map (H, W, 3) in [0, 1] at region positions u, v (v from
    the top), texel centres at (i + 0.5)/size, edges clamped."""
    h, w = image.shape[:2]
    x = np.clip(u * w - 0.5, 0, w - 1)
    y = np.clip(v_top * h - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    bottom = image[y1, x0] * (1 - fx) + image[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def region_pipeline(p, region_id, decode_png):
    """The region's colour pipeline as a function of encoded RGB (N, 3) and region
    positions u, v (from the top): the drive the standard's processing gives."""
    _, region = p.regions[region_id]
    color = region.find("color")
    fs = p.filesets[region_id]
    luts = {tag: read_cube(p.read(fs.findtext(f"{tag}/path")).decode()) for tag in ("decodeLUT", "correctLUT", "encodeLUT")}
    alpha = decode_png(p.read(p.path_of(region_id, "alphaMap")))
    beta = decode_png(p.read(p.path_of(region_id, "betaMap")))
    gamma = float(fs.findtext("alphaMap/gammaEmbedded"))
    correct = color.find("correct")
    matrix = None
    if correct.get("type") == "lut1d-primary":
        matrix = np.array(
            [[float(row.findtext(c)) for c in ("red", "green", "blue")] for row in correct.find("primaries")]
        )

    def run(encoded, u, v_top):
        linear = apply_1d(luts["decodeLUT"][1], encoded)
        (dim, n), table = luts["correctLUT"]
        if matrix is not None:
            corrected = apply_1d(table, linear) @ matrix.T
        else:
            corrected = apply_3d(table, n, linear)
        a = sample_map(alpha, u, v_top) ** gamma
        b = sample_map(beta, u, v_top)
        blended = corrected * a * (1 - b) + b
        (dim, n), table = luts["encodeLUT"]
        return apply_1d(table, blended) if dim == 1 else apply_3d(table, n, blended)

    return run


def nan_free(values):
    return all(not math.isnan(v) for v in values)
