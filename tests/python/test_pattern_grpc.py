"""The pattern service contract is language-neutral: a Python gRPC client generated
from ``pattern/proto/lumiwall/pattern/v1/pattern.proto`` (grpcio-tools, the same file
the Rust server is built from) drives ``lumiwall pattern-server --headless``.

Checks what any render engine's client or server must agree on: the token in the
``authorization`` metadata, the lease, exact code values at the output's bit depth
(read back as a 16-bit PNG with the codes in the high bits), rounding to a smaller
surface depth, black on the other outputs, the refusals with their status codes, and
the standard gRPC health service.
"""

import pathlib
import struct
import subprocess
import sys
import zlib

import pytest

grpc = pytest.importorskip("grpc")
grpc_tools = pytest.importorskip("grpc_tools.protoc")
health_pb2 = pytest.importorskip("grpc_health.v1.health_pb2")
health_pb2_grpc = pytest.importorskip("grpc_health.v1.health_pb2_grpc")

ROOT = pathlib.Path(__file__).resolve().parents[2]
PROTO_ROOT = ROOT / "pattern" / "proto"
PROTO = PROTO_ROOT / "lumiwall" / "pattern" / "v1" / "pattern.proto"
TOKEN = "python-client-token-0123456789"


@pytest.fixture(scope="module")
def stubs(tmp_path_factory):
    """pattern_pb2 and pattern_pb2_grpc, generated from the repository's .proto."""
    out = tmp_path_factory.mktemp("stubs")
    rc = grpc_tools.main(
        [
            "grpc_tools.protoc",
            f"-I{PROTO_ROOT}",
            f"--python_out={out}",
            f"--grpc_python_out={out}",
            str(PROTO),
        ]
    )
    assert rc == 0, "protoc failed on pattern.proto"
    sys.path.insert(0, str(out))
    from lumiwall.pattern.v1 import pattern_pb2, pattern_pb2_grpc  # noqa: E402

    return pattern_pb2, pattern_pb2_grpc


@pytest.fixture(scope="module")
def server(tmp_path_factory, lumiwall_bin):
    """A headless server with a 10-bit output and a 10-bit output on an 8-bit surface."""
    token = tmp_path_factory.mktemp("node") / "wall.token"
    token.write_text(TOKEN + "\n")
    proc = subprocess.Popen(
        [
            str(lumiwall_bin),
            "pattern-server",
            "--headless",
            "--listen",
            "127.0.0.1:0",
            "--token-file",
            str(token),
            "--settle",
            "0s",
            "--output",
            "DP-1=8x4@10",
            "--output",
            "DP-2=8x4@10/8",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert "listening on " in line, line
    addr = line.split("listening on ")[1].split()[0]
    yield addr
    proc.terminate()
    proc.wait(timeout=10)


def auth():
    return [("authorization", f"Bearer {TOKEN}")]


def png_rgb16(png_bytes):
    """Width, height and rows of 16-bit RGB samples of a PNG (a minimal decoder, so the
    check does not depend on an imaging library's idea of 16-bit PNGs)."""
    assert png_bytes[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, ihdr = 8, b"", None
    while pos < len(png_bytes):
        (n,) = struct.unpack(">I", png_bytes[pos : pos + 4])
        kind, data = png_bytes[pos + 4 : pos + 8], png_bytes[pos + 8 : pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", data)
        elif kind == b"IDAT":
            idat += data
    w, h, depth, colour, _, _, interlace = ihdr
    assert (depth, colour, interlace) == (16, 2, 0), ihdr
    raw, bpp, stride = zlib.decompress(idat), 6, 6 * w
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, rows


def codes(png_bytes, bits):
    """The set of RGB codes of a 16-bit PNG holding `bits`-bit codes in its high bits."""
    w, _, rows = png_rgb16(png_bytes)
    shift = 16 - bits
    return {
        tuple(struct.unpack(">H", row[6 * x + 2 * c : 6 * x + 2 * c + 2])[0] >> shift for c in range(3))
        for row in rows
        for x in range(w)
    }


def test_python_client_drives_the_rust_server_with_exact_codes(server, stubs):
    pb, pb_grpc = stubs
    stub = pb_grpc.PatternServiceStub(grpc.insecure_channel(server))
    outs = stub.ListOutputs(pb.ListOutputsRequest(), metadata=auth(), timeout=5)
    assert [(o.name, o.width_px, o.height_px, o.bit_depth, o.surface_bit_depth) for o in outs.outputs] == [
        ("DP-1", 8, 4, 10, 10),
        ("DP-2", 8, 4, 10, 8),
    ]
    lease = stub.Acquire(
        pb.AcquireRequest(station="python-station", protocol="lumiwall.pattern.v1"),
        metadata=auth(),
        timeout=5,
    ).lease
    shown = stub.ShowUniform(
        pb.ShowUniformRequest(lease=lease, output="DP-1", code=[1023, 512, 3], bit_depth=10),
        metadata=auth(),
        timeout=5,
    )
    assert shown.surface_bit_depth == 10 and shown.frame >= 1
    back = stub.ReadBack(pb.ReadBackRequest(lease=lease, output="DP-1"), metadata=auth(), timeout=5)
    assert (back.width_px, back.height_px, back.surface_bit_depth) == (8, 4, 10)
    assert (codes(back.png, 10)) == {(1023, 512, 3)}
    other = stub.ReadBack(pb.ReadBackRequest(lease=lease, output="DP-2"), metadata=auth(), timeout=5)
    assert (codes(other.png, 8)) == {(0, 0, 0)}, "the other output shows black"
    stub.ShowUniform(
        pb.ShowUniformRequest(lease=lease, output="DP-2", code=[1023, 512, 3], bit_depth=10),
        metadata=auth(),
        timeout=5,
    )
    rounded = stub.ReadBack(pb.ReadBackRequest(lease=lease, output="DP-2"), metadata=auth(), timeout=5)
    assert (codes(rounded.png, 8)) == {(255, 128, 1)}, "10-bit codes rounded to the 8-bit surface"
    stub.Release(pb.ReleaseRequest(lease=lease), metadata=auth(), timeout=5)


def test_refusals_carry_the_documented_status_codes(server, stubs):
    pb, pb_grpc = stubs
    stub = pb_grpc.PatternServiceStub(grpc.insecure_channel(server))
    with pytest.raises(grpc.RpcError) as e:
        stub.ListOutputs(pb.ListOutputsRequest(), timeout=5)
    assert e.value.code() == grpc.StatusCode.UNAUTHENTICATED
    with pytest.raises(grpc.RpcError) as e:
        stub.Acquire(pb.AcquireRequest(station="py", protocol="lumiwall.pattern.v0"), metadata=auth(), timeout=5)
    assert e.value.code() == grpc.StatusCode.FAILED_PRECONDITION
    assert "lumiwall.pattern.v1" in e.value.details()
    lease = stub.Acquire(
        pb.AcquireRequest(station="py", protocol="lumiwall.pattern.v1"), metadata=auth(), timeout=5
    ).lease
    with pytest.raises(grpc.RpcError) as e:
        stub.Acquire(pb.AcquireRequest(station="other", protocol="lumiwall.pattern.v1"), metadata=auth(), timeout=5)
    assert e.value.code() == grpc.StatusCode.FAILED_PRECONDITION
    assert "busy (held by py since" in e.value.details()
    with pytest.raises(grpc.RpcError) as e:
        stub.ShowUniform(
            pb.ShowUniformRequest(lease=lease, output="DP-1", code=[1024, 0, 0], bit_depth=10),
            metadata=auth(),
            timeout=5,
        )
    assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    with pytest.raises(grpc.RpcError) as e:
        stub.ShowUniform(
            pb.ShowUniformRequest(lease=lease, output="HDMI-9", code=[1, 1, 1], bit_depth=10),
            metadata=auth(),
            timeout=5,
        )
    assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT and "DP-1, DP-2" in e.value.details()
    stub.Release(pb.ReleaseRequest(lease=lease), metadata=auth(), timeout=5)


def test_the_standard_health_service_says_serving(server):
    health = health_pb2_grpc.HealthStub(grpc.insecure_channel(server))
    r = health.Check(
        health_pb2.HealthCheckRequest(service="lumiwall.pattern.v1.PatternService"), timeout=5
    )
    assert r.status == health_pb2.HealthCheckResponse.SERVING
