"""Shared fixtures of the Python module's tests: the repository's examples, the `cfuse`
program beside the module (CFUSE_EXE) for round trips, and ViSP's Castle-simu frames."""
import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(os.environ.get("CFUSE_SOURCE_DIR", Path(__file__).resolve().parents[2]))
CASTLE = Path("/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu")


@pytest.fixture
def examples():
    return ROOT / "examples"


@pytest.fixture
def cli():
    """Runs the `cfuse` program: (exit status, stdout, stderr)."""
    exe = os.environ.get("CFUSE_EXE")
    if not exe:
        pytest.skip("CFUSE_EXE not set")

    def run(*args):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        return p.returncode, p.stdout, p.stderr
    return run


def read_pgm(path):
    """A binary PGM (P5, 8 bits) as a numpy (H, W) uint8 array."""
    data = Path(path).read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    assert fields[0] == b"P5" and int(fields[3]) == 255
    width, height = int(fields[1]), int(fields[2])
    return np.frombuffer(data[pos + 1:pos + 1 + width * height], np.uint8).reshape(height, width)


def castle_truth(k):
    """Castle-simu's true camera-from-object pose of frame k: rotation (3, 3), translation (3,)."""
    rows = [list(map(float, line.split()))
            for line in (CASTLE / f"CameraPose/Camera_{k:03d}.txt").read_text().splitlines()
            if line.strip()]
    m = np.array(rows)
    return m[:3, :3], m[:3, 3]


def quaternion(r):
    """w, x, y, z of a rotation matrix (Shepperd's method: the largest of the four first)."""
    t = np.trace(r)
    candidates = [t, r[0, 0], r[1, 1], r[2, 2]]
    i = int(np.argmax(candidates))
    if i == 0:
        s = 2 * math.sqrt(1 + t)
        q = [s / 4, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    elif i == 1:
        s = 2 * math.sqrt(1 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [(r[2, 1] - r[1, 2]) / s, s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
    elif i == 2:
        s = 2 * math.sqrt(1 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s]
    else:
        s = 2 * math.sqrt(1 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4]
    return [float(v) for v in q]


@pytest.fixture
def castle():
    if not CASTLE.exists():
        pytest.skip("visp-images-data is not installed")
    return CASTLE


def write_json(path, value):
    Path(path).write_text(json.dumps(value))
    return path
