"""The simulated rig: its physics (no ports), its faults, and its pseudo-terminals."""

import io
import os
import select
import threading
import time

import numpy as np
import pytest
from PIL import Image

from refsynth.acquisition.faults import Faults
from refsynth.acquisition.geometry import (
    ENCODER_HORIZON,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    SLICE_COUNT,
    SLICE_START,
    camera_indices,
    camera_rays,
    directions,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.rangefinder_protocol import decode_samples, parse_rangefinder_reply
from refsynth.acquisition.simulator import RigSimulator, RoomRig
from refsynth.scenes import cast_rays, room_geometry, synthetic_room

# ----------------------------------------------------------------------------- geometry


def test_angles_follow_the_rig():
    assert np.degrees(pan_angle(250)) == 0.0
    np.testing.assert_allclose(np.degrees(pan_angle([0, 499])), [-90.0, 89.64], atol=1e-12)
    assert np.degrees(polar_angle(ENCODER_HORIZON)) == 90.0
    np.testing.assert_allclose(
        np.degrees(polar_angle([SLICE_START, SLICE_START + SLICE_COUNT - 1])),
        [68.22, 111.78], atol=1e-9)
    assert camera_indices().tolist() == list(range(25, 500, 50))
    np.testing.assert_allclose(np.degrees(pan_angle(camera_indices()))[[0, -1]], [-81, 81])
    # straight ahead, to the right, straight up
    np.testing.assert_allclose(directions(np.pi / 2, 0.0), [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(directions(np.pi / 2, np.pi / 2), [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(directions(0.0, 1.0), [0, 1, 0], atol=1e-15)


def test_camera_centre_ray_is_the_pan_direction():
    rays = camera_rays(75)
    assert rays.shape == (IMAGE_HEIGHT, IMAGE_WIDTH, 3)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=-1), 1.0, rtol=1e-12)
    # the four central pixels straddle the optical axis symmetrically
    centre = rays[IMAGE_HEIGHT // 2 - 1 : IMAGE_HEIGHT // 2 + 1,
                  IMAGE_WIDTH // 2 - 1 : IMAGE_WIDTH // 2 + 1].mean(axis=(0, 1))
    axis = directions(np.pi / 2, pan_angle(75))
    np.testing.assert_allclose(centre / np.linalg.norm(centre), axis, atol=1e-12)
    # a pixel right of centre turns further right (larger pan angle)
    right = rays[IMAGE_HEIGHT // 2, -1]
    assert np.arctan2(right[0], right[2]) > pan_angle(75)


def test_cast_rays_reproduces_synthetic_room():
    # the room the rig sees is the demo's room: same seed, same distances along the same rays
    scene = synthetic_room((32, 48), seed=3)
    room = room_geometry(3)
    focal = 24 / np.tan(np.radians(30))
    u = (np.arange(48) + 0.5 - 24) / focal
    v = (16 - (np.arange(32) + 0.5)) / focal
    camera = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)
    cos, sin = np.cos(room.yaw), np.sin(room.yaw)
    rays = camera @ np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    np.testing.assert_array_equal(cast_rays(room, rays).distance, scene.range)


# ----------------------------------------------------------------------------- physics


def test_slices_are_deterministic_and_independent_of_the_window():
    a, b = RoomRig(seed=2), RoomRig(seed=2)
    r1, a1 = a.measure(100, SLICE_START, SLICE_COUNT, 10)
    r2, a2 = b.measure(100, SLICE_START, SLICE_COUNT, 10)
    np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(a1, a2)
    # a sub-window gives the same values for the same encoder positions
    r3, a3 = a.measure(100, SLICE_START + 10, 20, 10)
    np.testing.assert_array_equal(r3, r1[10:30])
    np.testing.assert_array_equal(a3, a1[10:30])
    assert not np.array_equal(RoomRig(seed=3).measure(100, SLICE_START, SLICE_COUNT, 10)[0], r1)


def test_ranges_follow_the_room_within_the_noise():
    rig = RoomRig(seed=0)
    errors, returns = [], 0
    for pan in (0, 125, 250, 375, 499):
        range_mm, amplitude = rig.measure(pan, SLICE_START, SLICE_COUNT, 10)
        truth = rig.truth(pan, SLICE_START, SLICE_COUNT)
        ok = range_mm > 0
        returns += ok.sum()
        assert (amplitude[~ok] == 0).all() and (amplitude[ok] > 0).all()
        errors.append(range_mm[ok] / 1000.0 - truth[ok])
    errors = np.concatenate(errors)
    assert returns > 0.95 * 5 * SLICE_COUNT  # dropouts are rare on an indoor scene
    assert np.median(np.abs(errors)) < 0.003  # the mean of 10 samples: millimetres
    assert np.abs(errors).max() < 0.02


def test_amplitude_falls_with_incidence():
    rig = RoomRig(seed=0)
    encoder = np.arange(SLICE_START, SLICE_START + SLICE_COUNT)
    rays = directions(polar_angle(encoder), pan_angle(250))
    hits = cast_rays(rig.room, rays)
    incidence = np.abs(np.sum(rays * hits.normal, axis=-1))
    _, amplitude = rig.measure(250, SLICE_START, SLICE_COUNT, 10)
    ok = amplitude > 0
    per_albedo = amplitude[ok] / hits.albedo[ok]
    assert np.corrcoef(per_albedo, incidence[ok])[0, 1] > 0.5


def test_no_return_behind_the_open_room():
    # encoder 1500 looks horizontally backwards, out of the open side of the room
    range_mm, amplitude = RoomRig(seed=0).measure(250, 1490, 20, 10)
    assert (range_mm == 0).all() and (amplitude == 0).all()


def test_pictures_are_deterministic_pngs():
    rig = RoomRig(seed=1)
    picture = rig.picture(125)
    assert picture.shape == (IMAGE_HEIGHT, IMAGE_WIDTH) and picture.dtype == np.uint8
    assert picture.std() > 10
    np.testing.assert_array_equal(picture, RoomRig(seed=1).picture(125))
    decoded = np.asarray(Image.open(io.BytesIO(rig.picture_png(125))))
    np.testing.assert_array_equal(decoded, picture)
    assert rig.picture_png(125) == RoomRig(seed=1).picture_png(125)


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_room_rig_validation(bad):
    with pytest.raises(TypeError, match="`seed`"):
        RoomRig(bad)
    with pytest.raises(ValueError, match="pan_index"):
        RoomRig(0).measure(500, 0, 1, 1)


# ----------------------------------------------------------------------------- faults


def test_fault_specification():
    faults = Faults.parse("corrupt=0.05,drop=0.02,disconnect=1,delay=0.01")
    assert (faults.corrupt, faults.drop, faults.disconnect, faults.delay) == (0.05, 0.02, 1, 0.01)
    assert Faults.parse(str(faults)) == faults
    assert Faults.parse("none") == Faults.parse("") == Faults.parse(None) == Faults()
    assert str(Faults()) == "none" and not Faults().any and faults.any


@pytest.mark.parametrize(
    ("spec", "match"),
    [("corrupt", "unknown fault"), ("bogus=1", "unknown fault"), ("drop=x", "bad value"),
     ("drop=1.5", "fraction"), ("corrupt=0.6,drop=0.6", "add up"), ("disconnect=-1", ">= 0"),
     ("delay=-1", "delay"), ("disconnect=1.5", "bad value")],
)
def test_fault_specification_errors(spec, match):
    with pytest.raises(ValueError, match=match):
        Faults.parse(spec)


# ----------------------------------------------------------------------------- pseudo-terminals


def _exchange(fd: int, data: bytes, terminator: bytes, timeout: float = 2.0) -> bytes:
    """Write to a raw pty fd and read until ``terminator`` (bounded)."""
    os.write(fd, data)
    out = b""
    deadline = time.monotonic() + timeout
    while not out.endswith(terminator) and time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            out += os.read(fd, 4096)
    return out


@pytest.fixture
def pty_available():
    pytest.importorskip("pty")
    pytest.importorskip("termios")


def test_simulator_speaks_both_protocols_over_ptys(pty_available, tmp_path):
    threads = threading.active_count()
    with RigSimulator(seed=0, camera_dir=tmp_path) as sim:
        assert os.path.islink(sim.pan_port) and os.path.islink(sim.laser_port)
        pan = os.open(sim.pan_port, os.O_RDWR | os.O_NOCTTY)
        laser = os.open(sim.laser_port, os.O_RDWR | os.O_NOCTTY)
        try:
            assert _exchange(pan, b"PR ", b"\n") == b"* 1296.0000\r\n"
            assert _exchange(pan, b"PP600\r", b"\n") == b"! Maximum allowable pan position " \
                                                         b"exceeded\r\n"
            assert _exchange(pan, b"PP125 PP ", b"* 125\r\n") == b"*\r\n* 125\r\n"
            assert _exchange(pan, b"C ", b"\n") == b"* 125\r\n"
            assert (tmp_path / "pan-0125.png").is_file()
            assert _exchange(laser, b"GS0379024310\n", b"\n\n") == b"GS0379024310\n02\n\n"
            assert _exchange(laser, b"BM;1\n", b"\n\n") == b"BM;1\n00\n=FFFF\n\n"
            raw = _exchange(laser, b"GS0379024310;2\n", b"\n\n")
            reply = parse_rangefinder_reply(raw, b"GS0379024310;2\n")
            got = decode_samples(reply.payload, 243)
            expected = RoomRig(0).measure(125, 379, 243, 10)  # where the pan unit points
            np.testing.assert_array_equal(got[0], expected[0])
            assert _exchange(laser, b"XY\n", b"\n\n") == b"XY\n05\n\n"
            assert _exchange(laser, b"GS1999000210\n", b"\n\n") == b"GS1999000210\n01\n\n"
        finally:
            os.close(pan)
            os.close(laser)
        folder = os.path.dirname(sim.pan_port)
    assert not os.path.exists(folder)  # links removed
    deadline = time.monotonic() + 2
    while threading.active_count() > threads and time.monotonic() < deadline:
        time.sleep(0.01)
    assert threading.active_count() == threads  # threads stopped


def test_injected_faults_follow_their_rates(pty_available):
    faults = Faults(corrupt=0.3, drop=0.2, error=0.1)
    with RigSimulator(seed=4, faults=faults) as sim:
        fd = os.open(sim.pan_port, os.O_RDWR | os.O_NOCTTY)
        try:
            for _ in range(100):
                _exchange(fd, b"PP ", b"\n", timeout=0.02)
        finally:
            os.close(fd)
        stats = sim.stats()["pan unit"]
    assert stats["requests"] == 100
    assert 20 <= stats["corrupted"] <= 40 and 10 <= stats["dropped"] <= 30
    assert 3 <= stats["refused"] <= 18


def test_a_disconnect_moves_the_device_to_a_new_pty(pty_available):
    with RigSimulator(seed=0, faults=Faults(disconnect=1, disconnect_after=2),
                      reconnect_delay=0.05) as sim:
        fd = os.open(sim.laser_port, os.O_RDWR | os.O_NOCTTY)
        try:
            assert _exchange(fd, b"BM\n", b"\n\n").endswith(b"00\n=FFFF\n\n")
            os.write(fd, b"VV\n")  # the second request: the device vanishes instead
            hung_up = False
            deadline = time.monotonic() + 2
            while not hung_up and time.monotonic() < deadline:
                if select.select([fd], [], [], 0.05)[0]:
                    try:
                        hung_up = os.read(fd, 4096) == b""  # end of file: the other side is gone
                    except OSError:  # EIO on Linux
                        hung_up = True
            assert hung_up
        finally:
            os.close(fd)
        deadline = time.monotonic() + 2
        while not os.path.islink(sim.laser_port) and time.monotonic() < deadline:
            time.sleep(0.01)
        fd = os.open(sim.laser_port, os.O_RDWR | os.O_NOCTTY)
        try:
            # the device came back rebooted: laser off
            assert _exchange(fd, b"GS0379000110\n", b"\n\n") == b"GS0379000110\n02\n\n"
        finally:
            os.close(fd)
        assert sim.stats()["rangefinder"]["disconnects"] == 1
