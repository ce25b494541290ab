"""Bad input from Python: InputError (a ValueError) naming the file and the place; never a
crash of the interpreter."""
import numpy as np
import pytest

import cfuse


def test_model_file_errors_name_the_line_and_column(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ncomponents:\n  a:\n    points: {p: [0, 0]}\n")
    with pytest.raises(cfuse.InputError) as e:
        cfuse.load_model(str(bad))
    assert e.value.file == str(bad)
    assert e.value.line == 4 and e.value.column > 0
    assert isinstance(e.value, ValueError)
    assert str(bad) in str(e.value)


def test_missing_files():
    with pytest.raises(cfuse.InputError) as e:
        cfuse.load_model("/no/such/model.yaml")
    assert e.value.file == "/no/such/model.yaml"
    with pytest.raises(cfuse.InputError):
        cfuse.Camera.load("/no/such/camera.yaml")
    with pytest.raises(cfuse.InputError):
        cfuse.Measurements.load("/no/such/measurements.json")


@pytest.mark.parametrize("kwargs, element", [
    (dict(xyz=np.zeros((3, 2))), "xyz"),
    (dict(xyz=np.full((2, 3), np.nan)), "xyz[0]"),
    (dict(xyz=np.zeros((2, 3)), sigma=-1.0), "sigma"),
    (dict(xyz=np.zeros((2, 3)), sigma=np.array([1.0, 0.0])), "sigma[1]"),
    (dict(xyz=np.zeros((2, 3)), cov=np.zeros((2, 3, 3))), "cov[0]"),
    (dict(xyz=np.zeros((2, 3)), cov=np.ones((1, 3, 3))), "cov"),
    (dict(xyz=np.zeros((2, 3)), labels=["a"]), "labels"),
    (dict(xyz=np.zeros((2, 3)), sigma=1.0, cov=np.ones((2, 3, 3))), "sigma"),
    (dict(), "xyz"),
])
def test_measurements_refused_with_the_entry(kwargs, element):
    with pytest.raises(cfuse.InputError) as e:
        cfuse.Measurements(**kwargs)
    assert e.value.element == element
    assert e.value.file == "Measurements(...)"


def test_camera_refused_with_the_entry():
    with pytest.raises(cfuse.InputError) as e:
        cfuse.Camera(600, 600, 320, 240, 0, 480)
    assert e.value.element == "width"
    with pytest.raises(cfuse.InputError) as e:
        cfuse.Camera(600, 600, 320, 240, 640, 480, dist=[0.1, 0.2, 0.3])
    assert e.value.element == "dist"
    with pytest.raises(cfuse.InputError):
        cfuse.Camera(-600, 600, 320, 240, 640, 480)


def test_unknown_labels_and_options(examples):
    lamp = cfuse.load_model(examples / "lamp.yaml")
    with pytest.raises(cfuse.InputError):
        cfuse.solve(lamp, cfuse.Measurements(xyz=np.zeros((1, 3)), labels=["no_such_point"]))
    measurements, _ = cfuse.simulate(lamp, seed=1)
    with pytest.raises(cfuse.InputError) as e:
        cfuse.solve(lamp, measurements)  # unlabelled: for interpret
    assert "labelled" in e.value.message
    with pytest.raises(cfuse.InputError):
        cfuse.interpret(lamp, measurements, gate=2.0)
    for bad in (dict(noise=0.0), dict(occlusion=1.5), dict(clutter=-1.0)):
        with pytest.raises(cfuse.InputError):
            cfuse.simulate(lamp, **bad)


def test_images_refused(examples):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    camera = cfuse.Camera(600, 600, 320, 240, 640, 480)
    for image in (np.zeros((480, 640), np.float32), np.zeros((480, 640, 4), np.uint8),
                  np.zeros((48, 64), np.uint8), np.zeros((0, 640), np.uint8)):
        with pytest.raises(cfuse.InputError):
            cfuse.detect(box, camera, image)
    with pytest.raises(cfuse.InputError):
        cfuse.detect(box, camera, np.zeros((480, 640), np.uint8), order="yuv")
    lamp = cfuse.load_model(examples / "lamp.yaml")  # no edges
    with pytest.raises(cfuse.InputError):
        cfuse.Tracker(lamp, camera)


@pytest.mark.parametrize("call", [
    lambda m: cfuse.solve(None, None),
    lambda m: cfuse.solve(m, "measurements.json"),
    lambda m: cfuse.simulate(m, seed=-1),
    lambda m: cfuse.fk(m, {"hinge": float("nan")}),
    lambda m: cfuse.fk(m, {3: 1.0}),
    lambda m: cfuse.solve(m, cfuse.Measurements(xyz=np.zeros((2, 3)), labels=["box.c000", None]),
                          guess={"components": {"box": {"position": [0, 0], "quaternion": 1}}}),
    lambda m: cfuse.Tracker(m, cfuse.Camera(600, 600, 320, 240, 640, 480), init="/no/such.json"),
    lambda m: cfuse.Tracker(m, cfuse.Camera(600, 600, 320, 240, 640, 480), init={"x": object()}),
    lambda m: cfuse.detect(m, cfuse.Camera(600, 600, 320, 240, 640, 480), "image.png"),
    lambda m: cfuse.detect(m, cfuse.Camera(600, 600, 320, 240, 640, 480),
                           np.zeros((480, 640), np.uint8), max_results=0),
    lambda m: cfuse.Measurements(xyz="points"),
    lambda m: cfuse.Measurements(uv=np.zeros((2, 2)), camera="camera.yaml"),
    lambda m: cfuse.Camera.load(3),
    lambda m: cfuse.Tracker(m, cfuse.Camera(600, 600, 320, 240, 640, 480), max_branches=0),
])
def test_wrong_arguments_raise_and_the_interpreter_lives(examples, call):
    """Wrong types and values: an exception (InputError, TypeError or ValueError), never a
    crash; the interpreter goes on to the next case."""
    box = cfuse.load_model(examples / "hinged-box.yaml")
    with pytest.raises((cfuse.InputError, TypeError, ValueError, OverflowError)):
        call(box)


def test_interpret_releases_the_gil(examples):
    """Another thread runs while interpret searches (an image interpretation of some 100 ms)."""
    import threading
    import time
    box = cfuse.load_model(examples / "hinged-box.yaml")
    camera = cfuse.Camera(600, 600, 320, 240, 640, 480)
    measurements, _ = cfuse.simulate(box, seed=2, camera=camera, clutter=1)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)
    thread = threading.Thread(target=count)
    thread.start()
    start = time.perf_counter()
    cfuse.interpret(box, measurements)
    elapsed = time.perf_counter() - start
    done.set()
    thread.join()
    during = [t for t in ticks if start < t < start + elapsed]
    assert elapsed > 0.02
    # Held, the GIL would let the thread tick once or twice (Python's 5 ms switch interval
    # does not apply inside a C++ call); released, it ticks about every millisecond.
    assert len(during) > 0.3 * elapsed / 0.001


def test_no_interpretation_is_an_answer_not_an_error(examples):
    box = cfuse.load_model(examples / "hinged-box.yaml")
    result = cfuse.interpret(box, cfuse.Measurements(xyz=np.zeros((0, 3))))
    assert not result.converged and "no interpretation" in result.status
    assert result.to_dict() is None and result.components == {} and result.matches == []
