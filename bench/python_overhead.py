"""The cost of calling cfuse from Python over the C++ call it makes, measured in one run:
the lamp's solve (its labelled measurements, seed 1) and a tracked 640 x 480 frame (ViSP's
Castle-simu, frames 1-40 from frame 1's true pose), each timed from Python around the call and
in C++ around the library call (the result's time_ms). Prints a Markdown table.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py [--repeat N]
"""
import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import cfuse

ROOT = Path(__file__).resolve().parents[1]
CASTLE = Path("/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu")
sys.path.insert(0, str(ROOT / "tests/python"))
from conftest import castle_truth, quaternion, read_pgm  # noqa: E402


def timed(call, inner_ms, repeat):
    """Median ms from Python and inside C++ over `repeat` calls, interleaved."""
    outer, inner = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        value = call()
        outer.append(1000 * (time.perf_counter() - start))
        inner.append(inner_ms(value))
    return statistics.median(outer), statistics.median(inner)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=300)
    args = parser.parse_args()
    rows = []
    lamp = cfuse.load_model(ROOT / "examples/lamp.yaml")
    measurements, _ = cfuse.simulate(lamp, seed=1, labels=True)
    py, cc = timed(lambda: cfuse.solve(lamp, measurements),
                   lambda r: r.to_dict()["time_ms"], args.repeat)
    rows.append(("lamp solve (constraint fusion, 23 labelled points)", py, cc))
    if CASTLE.exists():
        model = cfuse.load_model(CASTLE / "Models/chateau.cao")
        camera = cfuse.Camera.load(CASTLE / "Config/chateau.xml")
        frames = [read_pgm(CASTLE / f"Images/Image_{k:04d}.pgm") for k in range(1, 41)]
        r, t = castle_truth(1)
        init = {"components": {"chateau": {"position": t.tolist(), "quaternion": quaternion(r)}}}
        outer, inner = [], []
        for _ in range(max(1, args.repeat // 40)):
            tracker = cfuse.Tracker(model, camera, init)
            for image in frames:
                start = time.perf_counter()
                frame = tracker.track(image)
                outer.append(1000 * (time.perf_counter() - start))
                inner.append(frame.time_ms)
        rows.append(("Castle-simu tracked frame (640 x 480, grey, read in place)",
                     statistics.median(outer), statistics.median(inner)))
    print("| call | from Python (ms, median) | C++ call (ms, median) | overhead |")
    print("|---|---|---|---|")
    for name, py, cc in rows:
        print(f"| {name} | {py:.3f} | {cc:.3f} | {100 * (py - cc) / cc:.1f} % |")


if __name__ == "__main__":
    main()
