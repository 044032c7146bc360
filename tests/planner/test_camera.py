"""The sensor from a camera: swath, sweep width, footprint and Pc per look, POD per pass."""

import math

import pytest

from planner.camera import Camera, camera_sensor


def test_sarenv_camera_45_degrees_at_80_m_over_30_m_cells():
    s = camera_sensor(Camera(45.0), 80.0, 30.0)
    assert s.swath_m == pytest.approx(2 * 80 * math.tan(math.radians(22.5)))  # 66.27 m
    assert s.sweep_width_m == pytest.approx(s.swath_m)
    assert s.footprint_radius == 1  # 3 cells of 30 m nearest the 66 m swath
    assert s.pc == pytest.approx(1 - math.exp(-s.sweep_width_m / (9 * 30.0)))
    # a cell crossed by the footprint's middle is read 3 times: POD = 1 - exp(-W L / A) over the 90 m strip
    assert 1 - (1 - s.pc) ** 3 == pytest.approx(s.pass_pod)
    assert s.pass_pod == pytest.approx(1 - math.exp(-66.274 * 30.0 / (90.0 * 30.0)), abs=1e-4)


def test_a_lower_layer_images_a_narrower_swath_and_a_poor_camera_sees_less():
    low, high = camera_sensor(Camera(45.0), 50.0, 30.0), camera_sensor(Camera(45.0), 120.0, 30.0)
    assert low.footprint_radius == 0 and high.footprint_radius == 1
    assert low.pc == pytest.approx(1 - math.exp(-41.42 / 30.0), abs=1e-4)
    thermal = camera_sensor(Camera(45.0, pixels=160, pd=0.8), 120.0, 30.0)  # 0.62 m pixels: 0.8 px on a person
    assert thermal.sweep_width_m == pytest.approx(0.8 * high.swath_m * (0.5 / (high.swath_m / 160)) / 2)
    assert thermal.pc < high.pc


def test_bad_cameras_and_a_pc_below_pf_are_refused():
    with pytest.raises(ValueError, match="--camera-fov"):
        Camera(0.0)
    with pytest.raises(ValueError, match="--camera-pd"):
        Camera(45.0, pd=1.5)
    with pytest.raises(ValueError, match="not above --pf"):
        camera_sensor(Camera(10.0, pd=0.1), 50.0, 30.0).sensor(0.1)
