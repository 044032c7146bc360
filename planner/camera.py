"""The sensor from a downward camera: its swath on the ground, an effective sweep width, and the
planner's sensor model (`planner.environment.Sensor`: a square footprint of cells and a
detection probability Pc per look at each) that spends the same search effort.

Search theory's default (Koopman's random search): effort W L over an area A finds a subject in
it with POD = 1 - exp(-W L / A), W the effective sweep width, L the track length. A camera at
altitude h with field of view F across track images a swath S = 2 h tan(F / 2); a subject in the
image is detected with probability p (`pd`; lowered where the camera resolves too few pixels on
it), so W = p S. The planner's footprint is the (2 r + 1)^2 cells around the UAV's cell, r the
radius whose width (2 r + 1) c is nearest the swath (c the cell side); every step (L = c) reads
each of them once, so a cell crossed by the footprint's middle is read 2 r + 1 times. Spreading
the step's effort W c over the footprint's (2 r + 1)^2 c^2 gives each look

    Pc = 1 - exp(-W / ((2 r + 1)^2 c)),

and a cell swept through gets POD = 1 - (1 - Pc)^(2 r + 1) = 1 - exp(-W / ((2 r + 1) c)): the
formula above over the strip the footprint sweeps."""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.environment import Sensor

#: The critical size of a person seen from above (shoulder width), metres.
PERSON_M = 0.5
#: Pixels across the critical size for detection (Johnson's criteria: one cycle, two pixels).
DETECT_PIXELS = 2.0


@dataclass(frozen=True)
class Camera:
    """A downward camera: `fov_deg` across track, `pixels` across track (None: resolution does not
    limit detection) and `pd`, the probability of detecting a subject in the image."""

    fov_deg: float
    pixels: int | None = None
    pd: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fov_deg) and 0 < self.fov_deg < 170):
            raise ValueError(f"--camera-fov must be between 0 and 170 degrees, got {self.fov_deg:g}")
        if self.pixels is not None and self.pixels < 1:
            raise ValueError(f"--camera-pixels must be at least 1, got {self.pixels}")
        if not (0 < self.pd <= 1):
            raise ValueError(f"--camera-pd must lie in (0, 1], got {self.pd:g}")

    def swath_m(self, altitude_m: float) -> float:
        return 2.0 * altitude_m * math.tan(math.radians(self.fov_deg) / 2.0)

    def detection(self, altitude_m: float) -> float:
        """p: `pd`, scaled down by the pixels on a person where they are fewer than DETECT_PIXELS."""
        if self.pixels is None:
            return self.pd
        on_person = PERSON_M / (self.swath_m(altitude_m) / self.pixels)
        return self.pd * min(1.0, on_person / DETECT_PIXELS)

    def sweep_width_m(self, altitude_m: float) -> float:
        """W = p S."""
        return self.detection(altitude_m) * self.swath_m(altitude_m)


@dataclass(frozen=True)
class CameraSensor:
    """What a camera at an altitude gives over `cell_size_m` cells: the swath, W, the footprint
    radius, Pc per look and the POD of one pass over a cell."""

    altitude_m: float
    swath_m: float
    sweep_width_m: float
    footprint_radius: int
    pc: float
    pass_pod: float

    def sensor(self, pf: float) -> Sensor:
        if not pf < self.pc:
            raise ValueError(f"the camera's Pc per look {self.pc:.3f} is not above --pf {pf:g}: lower --pf "
                             "(false alarms per look) or fly lower")
        return Sensor(self.pc, pf, self.footprint_radius)


def camera_sensor(camera: Camera, altitude_m: float, cell_size_m: float) -> CameraSensor:
    """The planner's footprint and Pc for `camera` at `altitude_m` over `cell_size_m` cells."""
    if not (math.isfinite(altitude_m) and altitude_m > 0):
        raise ValueError(f"the camera's altitude must be positive, got {altitude_m:g}")
    swath = camera.swath_m(altitude_m)
    width = camera.sweep_width_m(altitude_m)
    radius = max(0, round((swath / cell_size_m - 1.0) / 2.0))
    side = 2 * radius + 1
    pc = 1.0 - math.exp(-width / (side * side * cell_size_m))
    return CameraSensor(altitude_m, swath, width, radius, pc, 1.0 - math.exp(-width / (side * cell_size_m)))
