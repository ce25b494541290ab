"""The tracker fed frame by frame from numpy arrays, and detection, on ViSP's Castle-simu (its
renders and true poses are ViSP's, not ours)."""
import numpy as np
import pytest

import cfuse
from conftest import castle_truth, quaternion, read_pgm


def castle_setup(castle):
    model = cfuse.load_model(castle / "Models/chateau.cao")
    camera = cfuse.Camera.load(castle / "Config/chateau.xml")
    return model, camera


def error_mm(frame, k):
    _, t = castle_truth(k)
    return 1000 * np.linalg.norm(frame.components["chateau"].position - t)


def test_tracker_frame_by_frame(castle):
    model, camera = castle_setup(castle)
    r, t = castle_truth(1)
    init = {"components": {"chateau": {"position": t.tolist(), "quaternion": quaternion(r)}}}
    tracker = cfuse.Tracker(model, camera, init=init)
    for k in range(1, 11):
        frame = tracker.track(read_pgm(castle / f"Images/Image_{k:04d}.pgm"))
        assert frame.verified, (k, frame.refused)
        assert error_mm(frame, k) < 5
        assert frame.components["chateau"].covariance.shape == (6, 6)
        assert frame.fit.dof > 0 and 0 <= frame.fit.p_value <= 1
        assert frame.matches >= 6


def test_tracker_without_a_start_detects(castle):
    model, camera = castle_setup(castle)
    tracker = cfuse.Tracker(model, camera)
    frame = tracker.track(read_pgm(castle / "Images/Image_0001.pgm"))
    assert frame.verified and frame.detected
    assert error_mm(frame, 1) < 5
    tracker.skip()
    frame = tracker.track(read_pgm(castle / "Images/Image_0003.pgm"))
    assert frame.verified and error_mm(frame, 3) < 5


def castle_depth(castle, k):
    """Castle-simu's depth frame k as points in the grey camera's frame, read as ViSP's
    testGenericTrackerDepth.cpp reads it: uint32 height and width, then uint16 depths of
    0.000030518 m, through the depth camera (px = py = 700, u0 = 320, v0 = 240) that stands
    5 cm along -x in the grey camera's frame (depth_M_color's translation)."""
    path = castle / f"Depth/Depth_{k:04d}.bin"
    height, width = np.fromfile(path, dtype="<u4", count=2)
    z = np.fromfile(path, dtype="<u2", offset=8).reshape(height, width) * 0.000030518
    v, u = np.mgrid[0:height, 0:width]
    points = np.dstack([(u - 320) / 700 * z, (v - 240) / 700 * z, z])
    points[..., 0] += 0.05 * (z > 0)
    return points


def test_tracker_with_depth_frames(castle):
    model, camera = castle_setup(castle)
    r, t = castle_truth(1)
    init = {"components": {"chateau": {"position": t.tolist(), "quaternion": quaternion(r)}}}
    tracker = cfuse.Tracker(model, camera, init=init)
    for k in range(1, 11):
        frame = tracker.track(read_pgm(castle / f"Images/Image_{k:04d}.pgm"),
                              depth=castle_depth(castle, k).astype(np.float32))
        assert frame.verified, (k, frame.refused)
        assert error_mm(frame, k) < 1.5
    # The depth a wall 10 cm behind the castle: the faces are not where the sensor saw them.
    wall = castle_depth(castle, 11)
    wall[..., 2] += 0.1 * (wall[..., 2] > 0)
    # (frame 11 from frame 1's pose: verified with its own depth, refused with the wall's)
    image = read_pgm(castle / "Images/Image_0011.pgm")
    assert cfuse.Tracker(model, camera, init=init).track(
        image, depth=castle_depth(castle, 11)).verified
    assert not cfuse.Tracker(model, camera, init=init).track(image, depth=wall).verified
    for bad, words in ((np.zeros((4, 4, 3), dtype=np.int32), "must hold floats"),
                       (np.zeros((4, 4), dtype=np.float32), "must be of shape (H, W, 3)"),
                       ([[0.0, 0.0, 1.0]], "must be a numpy array")):
        with pytest.raises(cfuse.InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
            tracker.track(read_pgm(castle / "Images/Image_0011.pgm"), depth=bad)


def test_colour_and_strided_images_read_as_grey(castle):
    model, camera = castle_setup(castle)
    grey = read_pgm(castle / "Images/Image_0001.pgm")
    r, t = castle_truth(1)
    init = {"components": {"chateau": {"position": t.tolist(), "quaternion": quaternion(r)}}}
    reference = cfuse.Tracker(model, camera, init).track(grey).to_dict()
    for image, order in ((np.dstack([grey] * 3), "bgr"), (np.dstack([grey] * 3), "rgb"),
                         (np.asfortranarray(grey), "bgr"),
                         (np.dstack([grey, grey])[:, :, 0], "bgr")):
        frame = cfuse.Tracker(model, camera, init).track(image, order=order).to_dict()
        frame.pop("time_ms"), reference.pop("time_ms", None)
        assert frame == reference


def test_detect_matches_the_cli(castle, cli):
    import json
    model, camera = castle_setup(castle)
    image = read_pgm(castle / "Images/Image_0005.pgm")
    found = cfuse.detect(model, camera, image)
    assert found.found and len(found.objects) == 1
    assert found.objects[0].verified
    assert error_mm(found.objects[0], 5) < 5
    status, out, _ = cli("detect", castle / "Models/chateau.cao", "--camera",
                         castle / "Config/chateau.xml", "--image",
                         castle / "Images/Image_0005.pgm")
    assert status == 0
    theirs = json.loads(out)["objects"][0]
    ours = found.to_dict()["objects"][0]
    assert np.allclose(theirs["components"]["chateau"]["position"],
                       ours["components"]["chateau"]["position"], atol=1e-9)


def test_detect_in_noise_finds_nothing(castle):
    model, camera = castle_setup(castle)
    noise = np.random.default_rng(3).integers(0, 256, (480, 640), dtype=np.uint8)
    found = cfuse.detect(model, camera, noise)
    assert not found.found and found.why
