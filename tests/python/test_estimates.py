"""solve, interpret, simulate and fk from Python: the same answers as the `cfuse` program for
the same inputs, numpy shapes and dtypes, and verdicts."""
import json

import numpy as np
import pytest

import cfuse
from conftest import write_json


def without_time(d):
    d = dict(d)
    d.pop("time_ms", None)
    return d


def test_version_is_the_program_s(cli):
    status, out, _ = cli("--version")
    assert status == 0 and cfuse.__version__ in out


def test_model_names_and_check(examples, cli):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    assert box.name == "hinged file box"
    assert box.dof == 7
    assert box.components == ["box", "lid"]
    assert box.joints == ["hinge"]
    assert "box.c000" in box.points and "lid.l111" in box.points and len(box.points) == 16
    status, out, _ = cli("check", examples / "hinged-box.yaml", "--json")
    assert status == 0
    assert box.check() == json.loads(out)


def test_simulate_solve_round_trip_against_the_cli(examples, cli, tmp_path):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    measurements, truth = cfuse.simulate(box, seed=4, labels=True)
    assert measurements.xyz.shape == (16, 3) and measurements.xyz.dtype == np.float64
    assert measurements.cov.shape == (16, 3, 3)
    assert np.allclose(measurements.cov[0], 0.002 ** 2 * np.eye(3))
    assert measurements.labels == truth.matches
    result = cfuse.solve(box, measurements)
    assert result.converged and result.status == "converged"
    lid = result.components["lid"]
    assert lid.position.shape == (3,) and lid.quaternion.shape == (4,)
    assert lid.covariance.shape == (6, 6)
    assert np.allclose(lid.covariance, lid.covariance.T)
    assert abs(np.linalg.norm(lid.quaternion) - 1) < 1e-12
    # Within 5 sigmas of the truth, joint and position alike.
    hinge = result.joints["hinge"]
    assert abs(hinge.value - truth.joints["hinge"].value) < 5 * hinge.sigma
    sigma = np.sqrt(np.diag(lid.covariance)[3:])
    assert np.all(np.abs(lid.position - truth.components["lid"].position) < 5 * sigma)
    # The program on the same measurements writes the same result.
    path = write_json(tmp_path / "m.json", measurements.to_dict())
    status, out, _ = cli("solve", examples / "hinged-box.yaml", "--measurements", path)
    assert status == 0
    expected = without_time(json.loads(out))
    got = without_time(result.to_dict())
    assert json.dumps(got, sort_keys=True) == json.dumps(expected, sort_keys=True)


def test_measurements_from_numpy_match_a_file(examples, tmp_path):
    lamp = cfuse.load_model(examples / "lamp.yaml")
    measurements, _ = cfuse.simulate(lamp, seed=1, labels=True)
    again = cfuse.Measurements(xyz=measurements.xyz, cov=measurements.cov,
                               labels=measurements.labels)
    assert again.to_dict() == measurements.to_dict()
    path = write_json(tmp_path / "m.json", measurements.to_dict())
    loaded = cfuse.Measurements.load(str(path))
    assert np.array_equal(loaded.xyz, measurements.xyz)
    a = cfuse.solve(lamp, again).to_dict()
    b = cfuse.solve(lamp, loaded).to_dict()
    assert without_time(a) == without_time(b)
    sigma = cfuse.Measurements(xyz=measurements.xyz, sigma=0.002, labels=measurements.labels)
    assert np.allclose(sigma.cov, measurements.cov)


def test_image_points_need_their_camera(examples):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    camera = cfuse.Camera(600, 600, 320, 240, 640, 480)
    measurements, truth = cfuse.simulate(box, seed=3, camera=camera, labels=True)
    assert measurements.uv.shape == (16, 2) and np.isnan(measurements.xyz).all()
    assert measurements.cov.shape == (16, 2, 2)
    assert measurements.camera.fx == 600
    result = cfuse.solve(box, measurements)
    assert result.converged
    assert abs(result.joints["hinge"].value - truth.joints["hinge"].value) < \
        5 * result.joints["hinge"].sigma
    with pytest.raises(cfuse.InputError) as e:
        cfuse.Measurements(uv=measurements.uv)
    assert e.value.element == "camera"


def test_a_valley_of_tilt_is_named(examples):
    # A Stewart platform's top plate in one image (tests/interp/solve_valley_test.cpp): its fit
    # stays acceptable 30 degrees along its tilt, which the result names and the warning says.
    platform = cfuse.load_model(examples / "stewart-platform.yaml")
    camera = cfuse.Camera(800, 800, 320, 240, 640, 480)
    measurements, _ = cfuse.simulate(platform, seed=128, camera=camera, labels=True,
                                     sample_joints=True)
    result = cfuse.solve(platform, measurements)
    assert result.converged
    assert [v["component"] for v in result.valleys] == ["top"]
    assert result.valleys[0]["tilt_towards_mirror_rad"] > 0.3
    assert any(w.startswith("'top' can tilt") for w in result.warnings)


def test_interpret_against_the_cli(examples, cli, tmp_path):
    lamp = cfuse.load_model(examples / "lamp.yaml")
    measurements, truth = cfuse.simulate(lamp, seed=7, clutter=1, occlusion=0.1)
    assert all(label is None for label in measurements.labels)
    result = cfuse.interpret(lamp, measurements)
    assert result.converged
    assert result.search["status"] in ("complete", "found")
    right = sum(a == b for a, b in zip(result.matches, truth.matches))
    assert right == len(truth.matches)
    path = write_json(tmp_path / "m.json", measurements.to_dict())
    status, out, _ = cli("interpret", examples / "lamp.yaml", "--measurements", path)
    assert status == 0
    assert json.loads(out)["matches"] == result.matches


def test_a_wrong_answer_is_not_converged(examples):
    lamp = cfuse.load_model(examples / "lamp.yaml")
    measurements, _ = cfuse.simulate(lamp, seed=1, labels=True)
    labels = list(measurements.labels)
    labels[0], labels[5] = labels[5], labels[0]  # two points swapped: a wrong match
    swapped = cfuse.Measurements(xyz=measurements.xyz, cov=measurements.cov, labels=labels)
    result = cfuse.solve(lamp, swapped)
    assert not result.converged or result.warnings  # refused, or the outliers said
    assert result.status != "converged" or any("outlier" in w for w in result.warnings)


def test_guess_from_a_result(examples):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    measurements, _ = cfuse.simulate(box, seed=5, labels=True)
    first = cfuse.solve(box, measurements)
    again = cfuse.solve(box, measurements, guess=first)
    assert np.allclose(again.components["box"].position, first.components["box"].position,
                       atol=1e-6)
    parametric = cfuse.solve(box, measurements, method="parametric")
    assert parametric.to_dict()["status"]["method"] == "parametric"
    with pytest.raises(cfuse.InputError) as e:
        cfuse.solve(box, measurements, method="magic")
    assert e.value.file == "method"


def test_fk_against_the_cli(examples, cli, tmp_path):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    poses = cfuse.fk(box, {"hinge": 0.5})
    path = write_json(tmp_path / "q.json", {"hinge": 0.5})
    status, out, _ = cli("fk", examples / "hinged-box.yaml", "--joints", path)
    assert status == 0
    assert poses.to_dict() == json.loads(out)
    assert poses.joints["hinge"].value == 0.5
    with pytest.warns(UserWarning, match="beyond its limits"):
        cfuse.fk(box, {"hinge": 3.0})
    with pytest.raises(cfuse.InputError):
        cfuse.fk(box, {"hinge": "open"})


def test_image_points_with_covariances_and_interpretation(examples):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    camera = cfuse.Camera(600, 600, 320, 240, 640, 480)
    measurements, truth = cfuse.simulate(box, seed=11, camera=camera, clutter=0.5)
    cov = np.repeat(np.eye(2)[None], len(measurements), axis=0)
    again = cfuse.Measurements(uv=measurements.uv, cov=cov, camera=camera)
    assert again.to_dict() == measurements.to_dict()
    assert np.allclose(camera.project(np.array([[0.0, 0.0, 1.0]])), [[320, 240]])
    result = cfuse.interpret(box, again)
    assert result.converged, result.status
    # Labels may name a lid corner 10 mm from the true one, the same place in the image
    # (docs/benchmarks.md): the pose is what must be right.
    box_pose = result.components["box"]
    sigma = np.sqrt(np.diag(box_pose.covariance)[3:])
    assert np.all(np.abs(box_pose.position - truth.components["box"].position) < 5 * sigma)


def test_urdf_and_cao_models(examples, cli, tmp_path):
    arm = cfuse.load_model(examples.parent / "tests/data/urdf/arm.urdf")
    assert arm.joints and arm.components
    q = {"shoulder": 0.3, "elbow": -0.4, "slide": 0.05}  # grip_b mimics grip_a
    path = write_json(tmp_path / "q.json", q)
    status, out, _ = cli("fk", examples.parent / "tests/data/urdf/arm.urdf", "--joints", path)
    assert status == 0
    assert cfuse.fk(arm, q).to_dict() == json.loads(out)
    box = cfuse.load_model(examples.parent / "tests/data/cao/file_box.cao")
    assert box.components and box.dof == 6


@pytest.mark.parametrize("name", ["opencv_calibration.xml", "opencv_calibration.yml",
                                  "ros_camera_info.yaml"])
def test_camera_files(examples, name):
    camera = cfuse.Camera.load(examples.parent / "tests/data/cameras" / name)
    assert camera.fx > 0 and camera.fy > 0 and camera.width > 0 and camera.height > 0
    assert len(camera.dist) == 12
    # The principal point projects the optical axis.
    assert np.allclose(camera.project(np.array([[0.0, 0.0, 2.0]])), [[camera.cx, camera.cy]])
