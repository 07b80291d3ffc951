"""Cross-check of lumiwall's camera response curve (Debevec-Malik with Kresse's
15..250 mask, calib/src/camera/hdr.rs) against OpenCV-Python's CalibrateDebevec on the
same exposure stack of the virtual camera, and of both against the virtual camera's true
curve.

The Rust test ``exposure_stack_for_the_opencv_cross_check`` writes the stack (8-bit PNG
frames, exposure times, lumiwall's curve, the true curve) into LUMIWALL_STACK_DIR.
"""

import json
import os
import pathlib
import subprocess

import numpy as np

cv2 = __import__("cv2")

ROOT = pathlib.Path(__file__).resolve().parents[2]


def write_stack(folder: pathlib.Path) -> dict:
    """Runs the Rust test that writes the stack: the program scripts/test built
    (LUMIWALL_CAMERA_RESPONSE_TEST) or, without it, through cargo (a build of its own:
    about a minute more)."""
    env = dict(os.environ, LUMIWALL_STACK_DIR=str(folder))
    test = ["exposure_stack_for_the_opencv_cross_check", "--exact"]
    program = os.environ.get("LUMIWALL_CAMERA_RESPONSE_TEST")
    if program:
        assert pathlib.Path(program).is_file(), f"LUMIWALL_CAMERA_RESPONSE_TEST={program} is not a file"
        command = [program, *test]
    else:
        command = [
            "cargo", "test", "-q", "-p", "lumiwall-calib", "--features", "camera",
            "--test", "camera_response", "--", *test,
        ]
    subprocess.run(command, cwd=ROOT / "calib", env=env, check=True, capture_output=True)
    return json.loads((folder / "stack.json").read_text())


def max_relative_difference(a: np.ndarray, b: np.ndarray, codes: np.ndarray) -> float:
    """Largest |exp(a - b - median) - 1| over `codes`: curves equal up to scale."""
    d = a[codes] - b[codes]
    d = d - np.median(d)
    return float(np.max(np.abs(np.expm1(d))))


def test_lumiwall_response_curve_agrees_with_opencv_on_the_same_exposure_stack(tmp_path):
    stack = write_stack(tmp_path)
    images = [cv2.imread(str(tmp_path / name), cv2.IMREAD_COLOR) for name in stack["frames"]]
    assert all(img is not None for img in images)
    times = np.array(stack["exposures_s"], dtype=np.float32)
    opencv = cv2.createCalibrateDebevec(samples=300, lambda_=40.0, random=False).process(images, times)
    ln_opencv = np.log(np.maximum(opencv[:, 0, ::-1].T, 1e-30))  # BGR -> RGB, (3, 256)
    ln_ours = np.array(stack["ln_exposure"])
    truth = np.array(stack["true_relative_exposure"])
    for c in range(3):
        # Codes whose true exposure is 5..95 % of saturation, and at most 240: above
        # that OpenCV's unmasked solve bends (clipped samples enter it).
        codes = np.nonzero((truth[c] >= 0.05) & (truth[c] <= 0.95) & (np.arange(256) <= 240))[0]
        ln_truth = np.log(np.maximum(truth[c], 1e-12))
        between = max_relative_difference(ln_ours[c], ln_opencv[c], codes)
        ours_err = max_relative_difference(ln_ours[c], ln_truth, codes)
        opencv_err = max_relative_difference(ln_opencv[c], ln_truth, codes)
        print(f"channel {c}: codes {codes[0]}..{codes[-1]}: lumiwall vs OpenCV {between:.4f}, "
              f"lumiwall vs truth {ours_err:.4f}, OpenCV vs truth {opencv_err:.4f}")
        assert ours_err <= 0.01
        assert between <= 0.02
