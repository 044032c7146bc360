"""The colour of each UAV, the same in every picture, recording and map file (RGB 0-255)."""

UAV_COLOURS = ((31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14),
               (23, 190, 207), (227, 119, 194), (140, 86, 75), (188, 189, 34), (127, 127, 127))


def uav_colour(index: int) -> tuple[int, int, int]:
    """The colour of the index-th UAV (UAV id - 1), in the picture, the recording and the KML files."""
    return UAV_COLOURS[index % len(UAV_COLOURS)]
