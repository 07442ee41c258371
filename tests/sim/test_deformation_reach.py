"""Culling the cross-section maps by their reach along each image column: the reach against a
brute-force distance, and the culled inverse map against the same map with nothing culled,
bit for bit, on pressed frames of the femoral phantom (its junctions' rings overlap)."""

import numpy as np

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.deformation import (
    FrameDeformation,
    ProbeDeformation,
    TissueLoad,
    column_reach,
    undeform_points,
)
from sim.ultrasound.echo import grid_points
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.skin_pose import probe_pose_on_skin

PROBE = LinearProbe(width=0.038, depth=0.04, cols=64, rows=128)


def pixel_grid(pose: np.ndarray) -> np.ndarray:
    """The image's pixel centres in the phantom frame, column-major (as `render` lays them)."""
    pixel_to_phantom = pose @ PROBE.image_to_probe()
    points = np.empty((PROBE.rows * PROBE.cols, 3))
    origin, col_step, row_step = (np.ascontiguousarray(pixel_to_phantom[:3, k]) for k in (3, 0, 1))
    grid_points(origin, col_step, row_step, PROBE.rows, points)
    return points


def pressed_frames(count: int) -> list[tuple[np.ndarray, FrameDeformation]]:
    """Poses along the femoral vessels, pressed in 3 mm at 8 N, and each one's deformation."""
    phantom = Phantom(load_phantom("femoral"))
    deformation = ProbeDeformation(phantom, PROBE)
    frames = []
    for k, y in enumerate(np.linspace(-0.05, 0.05, count)):
        pose = probe_pose_on_skin(phantom, 0.003 * np.sin(k), y, rotation=0.1 * k, tilt=0.05)
        pose[:3, 3] += pose[:3, 2] * 0.003
        frames.append((pose, deformation.frame(pose, TissueLoad(8.0, k / 30))))
    return frames


def test_reach_holds_every_point_of_the_column_within_the_outer_radius():
    """Random vessels' rings (axis, outer radius, bulk shift) against two image columns: the
    reach is the stretch of each column within the ring, to the pad."""
    rng = np.random.default_rng(5)
    rows, height = PROBE.rows, PROBE.pixel_height
    pose = probe_pose_on_skin(Phantom(load_phantom("femoral")), 0.0, 0.0, rotation=0.3)
    beam = np.ascontiguousarray(pose[:3, 2])
    points = pixel_grid(pose)[: rows * 2]  # two columns
    maps = np.zeros((20, 19))
    for m in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        maps[m, 0:3] = points[0] + rng.normal(scale=0.01, size=3)
        maps[m, 3:6] = axis
        maps[m, 15] = rng.uniform(0.002, 0.012)
        maps[m, 18] = rng.uniform(-0.002, 0.002)
    reach = column_reach(points, rows, height, beam, maps)
    down = np.arange(rows) * height
    for m in range(20):
        for col in range(2):
            line = points[col * rows] + np.outer(down - maps[m, 18], beam) - maps[m, :3]
            along = line @ maps[m, 3:6]
            distance = np.sqrt(np.sum(line**2, axis=1) - along**2)
            inside = (reach[m, col, 0] <= down) & (down <= reach[m, col, 1])
            assert np.all(inside[distance < maps[m, 15]])
            assert np.all(distance[~inside] > maps[m, 15])
            assert np.all(distance[inside] < maps[m, 15] + 1e-5)


def test_culled_maps_move_every_point_exactly_as_the_maps_unculled_do():
    moved = 0
    for pose, frame in pressed_frames(12):
        assert frame.maps.shape[0] >= 2
        beam = np.ascontiguousarray(pose[:3, 2])
        culled, everything = pixel_grid(pose), pixel_grid(pose)
        reach = column_reach(culled, PROBE.rows, PROBE.pixel_height, beam, frame.maps)
        assert np.isinf(reach).any() or (reach[..., 0] > reach[..., 1]).any()  # some culled
        unbounded = np.empty_like(reach)
        unbounded[..., 0], unbounded[..., 1] = -np.inf, np.inf
        for points, bounds in ((culled, reach), (everything, unbounded)):
            undeform_points(
                points, PROBE.rows, PROBE.pixel_height, beam, frame.row_shift, frame.maps, bounds
            )
        assert np.array_equal(culled, everything)
        moved += int(np.any(np.abs(culled - pixel_grid(pose)) > 1e-5, axis=1).sum())
    assert moved > 1000
