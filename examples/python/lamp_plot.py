"""The desk lamp from unlabelled, cluttered 3D points: interpreted, estimated, and drawn with
each point's 2-sigma ellipsoid (docs/python.md).

    /usr/bin/python3 examples/python/lamp_plot.py [OUT.png]
"""
import sys
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import cfuse  # noqa: E402

# The lamp's skeleton, to draw it: base, swivel, the two parallelogram arms, the shade's rim.
SKELETON = [("p1", "p2"), ("p2", "p3"), ("p3", "p4"), ("p4", "p1"), ("p5", "p6"),
            ("p6", "p8"), ("p10", "p11"), ("p8", "p12"), ("p14", "p15"), ("p12", "p16"),
            ("p16", "p21"), ("p17", "p18"), ("p18", "p19"), ("p19", "p20"), ("p20", "p17")]
EXAGGERATION = 10  # the ellipsoids of 2 mm noise are invisible at the lamp's scale


def ellipsoid(centre, cov, sigmas=2.0, n=12):
    """A wireframe of the `sigmas`-sigma ellipsoid of a 3 x 3 covariance."""
    values, vectors = np.linalg.eigh(cov)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n // 2))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    radii = sigmas * EXAGGERATION * np.sqrt(np.maximum(values, 0))
    return centre + (sphere * radii) @ vectors.T


def main(out):
    root = Path(__file__).resolve().parents[2]
    lamp = cfuse.load_model(root / "examples/lamp.yaml")
    measurements, truth = cfuse.simulate(lamp, seed=3, clutter=2, occlusion=0.1)
    result = cfuse.interpret(lamp, measurements)
    if not result.converged:
        raise SystemExit(f"no answer: {result.status}")
    matched = np.array([m is not None for m in result.matches])
    error = max(np.linalg.norm(result.points[n].xyz - truth.points[n].xyz) for n in result.points)

    fig = plt.figure(figsize=(7, 7))
    ax = fig.add_subplot(projection="3d")
    xyz = measurements.xyz
    ax.scatter(*xyz[~matched].T, s=8, c="0.6", label="clutter")
    ax.scatter(*xyz[matched].T, s=14, c="tab:blue", label="measured, matched")
    for a, b in SKELETON:
        p, q = result.points[a].xyz, result.points[b].xyz
        ax.plot(*np.stack([p, q]).T, c="tab:orange", lw=2)
    for name, point in result.points.items():
        surface = ellipsoid(point.xyz, point.cov)
        ax.plot_wireframe(*np.moveaxis(surface, -1, 0), color="tab:red", lw=0.3)
    ax.plot([], [], c="tab:orange", lw=2, label="estimate")
    ax.plot([], [], c="tab:red", lw=0.5, label=f"2-sigma ellipsoids (x{EXAGGERATION})")
    ax.set_title(f"{result.fit}; {int(matched.sum())} of {len(xyz)} points matched; "
                 f"worst point {1000 * error:.1f} mm off", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    centre = np.mean([p.xyz for p in result.points.values()], axis=0)
    for set_limits, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        set_limits(c - 0.35, c + 0.35)
    ax.view_init(elev=-35, azim=-115, roll=0)  # from beside the camera, which looks along +z
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f"{out}: {result.fit}, worst point {1000 * error:.1f} mm from the truth")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "lamp.png")
