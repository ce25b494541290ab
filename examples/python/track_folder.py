"""Tracking over a folder of images with no starting pose (docs/python.md):

    /usr/bin/python3 examples/python/track_folder.py MODEL CAMERA FOLDER [--init POSE]

e.g. ViSP's Castle-simu from Debian's visp-images-data:

    D=/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu
    /usr/bin/python3 examples/python/track_folder.py $D/Models/chateau.cao \
        $D/Config/chateau.xml $D/Images
"""
import argparse
from pathlib import Path

import numpy as np
from PIL import Image

import cfuse


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("camera")
    parser.add_argument("folder")
    parser.add_argument("--init", help="the first frame's pose (results file or ViSP .pos)")
    args = parser.parse_args()
    model = cfuse.load_model(args.model)
    tracker = cfuse.Tracker(model, cfuse.Camera.load(args.camera), init=args.init)
    root = model.components[0]
    verified = 0
    frames = sorted(p for p in Path(args.folder).iterdir()
                    if p.suffix.lower() in (".png", ".pgm", ".jpg", ".jpeg", ".ppm"))
    for path in frames:
        image = np.asarray(Image.open(path).convert("L"))  # (H, W) uint8, read in place
        frame = tracker.track(image)
        if frame.verified:
            verified += 1
            x, y, z = frame.components[root].position
            how = " (detected)" if frame.detected else ""
            print(f"{path.name}: {root} at ({x:.4f}, {y:.4f}, {z:.4f}) m, "
                  f"p = {frame.fit.p_value:.2f}{how}")
        else:
            print(f"{path.name}: not verified: {frame.refused}")
    print(f"{verified} of {len(frames)} frames verified")


if __name__ == "__main__":
    main()
