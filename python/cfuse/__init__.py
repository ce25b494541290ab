"""cfuse: model-based pose estimation, interpretation and tracking of articulated and
constrained objects.

Everything the `cfuse` program does on files, on Python objects and numpy arrays::

    import cfuse
    model = cfuse.load_model("examples/lamp.yaml")
    measurements, truth = cfuse.simulate(model, seed=1, labels=True)
    result = cfuse.solve(model, measurements)
    result.components["base"].position      # (3,) metres
    result.components["base"].covariance    # (6, 6): rotation, then translation
    result.to_dict()                        # what `cfuse solve` writes

A result is right as far as the data can tell only when ``result.converged`` is true;
``result.status`` says why not, ``result.warnings`` what the data leave open.
Bad input raises :class:`InputError` (a ValueError) with ``file``, ``line``, ``column`` and
``element`` naming the place.
"""
from __future__ import annotations

import functools
import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from ._cfuse import (Camera, InputError, InternalError, Measurements, Model,  # noqa: F401
                     load_model)
from . import _cfuse

__version__: str = _cfuse.__version__

__all__ = [
    "Camera", "InputError", "InternalError", "Measurements", "Model", "load_model",
    "Pose", "Joint", "Point", "Fit", "Result", "Poses", "Truth", "Frame", "Detection",
    "NoAnswerError",
    "simulate", "solve", "interpret", "fk", "Tracker", "detect",
]

PathLike = Union[str, "os.PathLike[str]"]


class NoAnswerError(RuntimeError):
    """The data or the model admit no answer (e.g. fk at joint values where a closed chain
    cannot close). The message says why."""


class Pose:
    """A rigid component's pose in the camera (viewer) frame: ``position`` (3,) in metres,
    ``quaternion`` (4,) as w, x, y, z, and ``covariance`` (6, 6) of [rotation; translation]
    when the answer has one (else None)."""

    def __init__(self, d: Dict[str, Any], covariance: Any = None):
        self.position = np.asarray(d["position"], dtype=float)
        self.quaternion = np.asarray(d["quaternion"], dtype=float)
        cov = d.get("covariance", covariance)
        self.covariance = None if cov is None else np.asarray(cov, dtype=float)

    def rotation(self) -> np.ndarray:
        """The (3, 3) rotation matrix of the quaternion."""
        w, x, y, z = self.quaternion
        return np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

    def __repr__(self) -> str:
        return f"Pose(position={self.position.tolist()}, quaternion={self.quaternion.tolist()})"


class Joint:
    """A joint variable: ``value`` (radians or metres) and ``sigma`` (None when not estimated)."""

    def __init__(self, d: Dict[str, Any]):
        self.value = float(d["value"])
        self.sigma = None if d.get("sigma") is None else float(d["sigma"])

    def __repr__(self) -> str:
        return f"Joint(value={self.value}, sigma={self.sigma})"


class Point:
    """A single point: ``xyz`` (3,) in metres and ``cov`` (3, 3) (None when not estimated)."""

    def __init__(self, d: Any):
        if isinstance(d, dict):
            self.xyz = np.asarray(d["xyz"], dtype=float)
            self.cov = None if d.get("cov") is None else np.asarray(d["cov"], dtype=float)
        else:
            self.xyz, self.cov = np.asarray(d, dtype=float), None

    def __repr__(self) -> str:
        return f"Point(xyz={self.xyz.tolist()})"


class Fit:
    """The goodness of fit of the whitened residuals at the estimate: ``chi2`` over ``dof``
    degrees of freedom, and its ``p_value`` (None when there is nothing to test)."""

    def __init__(self, d: Dict[str, Any]):
        self.chi2 = float(d.get("chi2", 0.0))
        self.dof = int(d.get("dof", 0))
        self.p_value = None if d.get("p_value") is None else float(d["p_value"])

    def __repr__(self) -> str:
        p = "None" if self.p_value is None else f"{self.p_value:.3g}"
        return f"Fit(chi2={self.chi2:.4g}, dof={self.dof}, p_value={p})"


class Poses:
    """Poses of a model: ``components`` (name -> :class:`Pose`), ``points`` (name ->
    :class:`Point`) and ``joints`` (name -> :class:`Joint`), with ``to_dict()`` giving the
    CLI's JSON for the same answer."""

    def __init__(self, d: Optional[Dict[str, Any]]):
        self._dict = d
        d = d or {}  # no answer at all (an interpretation that matched nothing)

    # Built on first use: a result's numpy arrays cost more than the call for a small model.
    @functools.cached_property
    def components(self) -> Dict[str, Pose]:
        d = self._dict or {}
        covariances = d.get("covariance", {})
        return {name: Pose(p, covariances.get(name)) for name, p in d.get("components", {}).items()}

    @functools.cached_property
    def points(self) -> Dict[str, Point]:
        return {n: Point(p) for n, p in (self._dict or {}).get("points", {}).items()}

    @functools.cached_property
    def joints(self) -> Dict[str, Joint]:
        return {n: Joint(j) for n, j in (self._dict or {}).get("joints", {}).items()}

    def to_dict(self) -> Optional[Dict[str, Any]]:
        """The answer as the `cfuse` program writes it (docs/formats.md); None when there is
        none (the program writes nothing)."""
        return self._dict


class Truth(Poses):
    """What :func:`simulate` measured: the poses and joints, and ``matches`` (per measurement:
    the model point it measures, or None for clutter). ``to_dict()`` is the truth file."""

    def __init__(self, d: Dict[str, Any]):
        super().__init__(d)
        self.matches: List[Optional[str]] = list(d.get("matches", []))


class Result(Poses):
    """The answer of :func:`solve` or :func:`interpret`: the poses with covariances, the
    joints, ``matches`` (per measurement: the model point it was matched to, or None),
    ``fit``, ``converged`` (right as far as the data can tell), ``status`` (why not, or
    "converged"), ``warnings`` (what the data leave open), ``undetermined``, ``alternatives``
    and ``valleys`` (docs/formats.md)."""

    def __init__(self, d: Optional[Dict[str, Any]], status: int, lines: List[str]):
        super().__init__(d)
        d = d or {}
        self.matches: List[Optional[str]] = list(d.get("matches", []))
        self.fit = Fit(d.get("fit", {}))
        self.undetermined: List[str] = list(d.get("undetermined", []))
        self.alternatives: List[Poses] = [Poses(a) for a in d.get("alternatives", [])]
        self.valleys: List[Dict[str, Any]] = list(d.get("valleys", []))
        self.search: Optional[Dict[str, Any]] = d.get("search")
        self.warnings = [line[len("warning: "):] for line in lines if line.startswith("warning: ")]
        reasons = [line for line in lines if not line.startswith("warning: ")]
        self.converged = status == 0
        self.status = "converged" if self.converged else "; ".join(reasons)

    def __repr__(self) -> str:
        return f"<cfuse.Result {self.status!r}, {self.fit}>"


class Frame(Poses):
    """One tracked or detected frame: the poses with covariances, the joints, ``verified``
    (the outline verified against the image: a verified frame is right as far as the image
    tells), ``matches`` (edges matched), ``fit``, ``outline`` (its verification's figures),
    ``refused`` (why not verified, or None), ``detected`` (found with no pose given)."""

    def __init__(self, d: Dict[str, Any]):
        super().__init__(d)
        self.verified = bool(d.get("verified", False))
        self.matches = int(d.get("matches", 0))
        self.fit = Fit(d.get("fit", {}))
        self.outline: Dict[str, Any] = d.get("outline", {})
        self.refused: Optional[str] = d.get("refused")
        self.detected = bool(d.get("detected", False))
        self.time_ms: Optional[float] = d.get("time_ms")

    def __repr__(self) -> str:
        state = "verified" if self.verified else f"lost ({self.refused})"
        return f"<cfuse.Frame {state}, {self.matches} matches>"


class Detection:
    """What :func:`detect` found: ``found``, ``objects`` (each a :class:`Frame`, best first),
    ``why`` (when nothing was found), ``refused`` (the best candidates refused, as Frames),
    ``stats`` and ``to_dict()`` (what `cfuse detect` writes)."""

    def __init__(self, d: Dict[str, Any]):
        self._dict = d
        self.found = bool(d["found"])
        self.objects = [Frame(o) for o in d["objects"]]
        self.refused = [Frame(o) for o in d.get("refused", [])]
        self.why: Optional[str] = d.get("why")
        self.stats: Dict[str, Any] = d.get("stats", {})

    def to_dict(self) -> Dict[str, Any]:
        return self._dict

    def __repr__(self) -> str:
        return f"<cfuse.Detection {'found' if self.found else 'not found: ' + str(self.why)}>"


def _poses_dict(poses: Any, what: str) -> Any:
    """A path stays a path; a Result, Frame or Poses gives its dict; a dict is taken as it is."""
    if poses is None or isinstance(poses, (str, os.PathLike, dict)):
        return os.fspath(poses) if isinstance(poses, os.PathLike) else poses
    if hasattr(poses, "to_dict"):
        return poses.to_dict()
    raise TypeError(f"{what}: a path, a dict in the results format, or a Result, not "
                    f"{type(poses).__name__}")


def simulate(model: Model, seed: int = 0, noise: float = 0.002, clutter: float = 0.0,
             occlusion: float = 0.0, labels: bool = False, camera: Optional[Camera] = None,
             pixel_noise: float = 1.0, sample_joints: bool = False
             ) -> Tuple[Measurements, Truth]:
    """Measurements of the model at a random pose, as `cfuse simulate` makes them: noise
    (metres; ``pixel_noise`` in pixels with a camera), clutter (extra points per real one),
    occlusion (the share of model points not measured), labels kept or not. Returns the
    measurements and the truth (its ``to_dict()`` is the truth file, with ``matches``)."""
    measurements, truth = _cfuse._simulate(model, seed, noise, pixel_noise, clutter, occlusion,
                                           labels, sample_joints, camera)
    return measurements, Truth(truth)


def solve(model: Model, measurements: Measurements, guess: Any = None,
          method: str = "fusion") -> Result:
    """Every component's pose from labelled measurements, as `cfuse solve`: ``method`` is
    "fusion" (constraint fusion), "parametric" or "components"; ``guess`` a results file's
    path, its dict, or a Result to start from."""
    return Result(*_cfuse._solve(model, measurements, _poses_dict(guess, "guess"), method))


def interpret(model: Model, measurements: Measurements, gate: float = 0.9999,
              max_nodes: int = 20000) -> Result:
    """Which measurement is which model point, and the poses, from unlabelled measurements
    with clutter and occlusion, as `cfuse interpret` (the interpretation tree).
    ``result.search`` holds the search's statistics."""
    return Result(*_cfuse._interpret(model, measurements, gate, max_nodes))


def fk(model: Model, joints: Optional[Dict[str, float]] = None) -> Poses:
    """Every component's pose at the given joint values (radians, metres; the others at the
    model's positions), closed chains closed, as `cfuse fk`. Warnings (a value beyond its
    limits) go to Python's warnings; a chain that cannot close raises NoAnswerError."""
    import warnings
    result, status, lines = _cfuse._fk(model, dict(joints or {}))
    for line in lines:
        if line.startswith("warning: "):
            warnings.warn(line[len("warning: "):], stacklevel=2)
    if status != 0:
        raise NoAnswerError("; ".join(l for l in lines if not l.startswith("warning: ")))
    return Poses(result)


class Tracker:
    """The model tracked over a sequence of images (`cfuse track`): ``init`` is the first
    frame's pose (a results file or ViSP .pos path, a dict in the results format, or a
    Result); without it the first frame is detected, as is any frame after the object has
    been lost for two. ``max_branches``: match sets tried per search range, as `cfuse track
    --max-branches`. Feed it frames with :meth:`track`."""

    def __init__(self, model: Model, camera: Camera, init: Any = None, max_branches: int = 5):
        self._tracker = _cfuse._Tracker(model, camera, _poses_dict(init, "init"), max_branches)

    def track(self, image: np.ndarray, order: str = "bgr",
              depth: Optional[np.ndarray] = None) -> Frame:
        """One frame: a numpy uint8 image (H, W) grey, read in place, or (H, W, 3) colour
        (``order`` "bgr" as OpenCV captures it, or "rgb"). ``depth``: a range sensor's frame
        taken with it, as points (H', W', 3) in metres in this camera's frame (z <= 0 or NaN:
        no depth), fused with the edges as `cfuse track --depth` does."""
        return Frame(self._tracker.track(image, order, depth))

    def skip(self) -> None:
        """A frame with no image: the prediction spans it."""
        self._tracker.skip()


def detect(model: Model, camera: Camera, image: np.ndarray, max_results: int = 1,
           order: str = "bgr") -> Detection:
    """The model found in one image with no pose given, as `cfuse detect`."""
    return Detection(_cfuse._detect(model, camera, image, max_results, order))
