"""docs/python.md's example programs run as written."""
import os
import subprocess
import sys

from conftest import ROOT


def run(*args):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True,
                          env=env)


def test_lamp_plot(tmp_path):
    out = tmp_path / "lamp.png"
    p = run(ROOT / "examples/python/lamp_plot.py", out)
    assert p.returncode == 0, p.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "mm from the truth" in p.stdout


def test_track_folder(castle, tmp_path):
    # The first five frames, with no starting pose: the first is detected.
    for k in range(1, 6):
        (tmp_path / f"Image_{k:04d}.pgm").symlink_to(castle / f"Images/Image_{k:04d}.pgm")
    p = run(ROOT / "examples/python/track_folder.py", castle / "Models/chateau.cao",
            castle / "Config/chateau.xml", tmp_path)
    assert p.returncode == 0, p.stderr
    assert "(detected)" in p.stdout.splitlines()[0]
    assert p.stdout.splitlines()[-1] == "5 of 5 frames verified"
