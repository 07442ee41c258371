"""A vessel map logged to rerun, saved and read back: its surfaces and needle, from the
millimetres of the map's files to the metres of the scene."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import trimesh
from rerun_readback import Recording

from resus.visualize import open_recording
from resus.visualize.vessels import NEEDLE_COLOUR, log_vessel_map
from sim.labels import ARTERY, label_colour

ENTRY_MM, TARGET_MM = [-290.0, -130.0, 60.0], [-300.0, -130.0, 40.0]


def packed(rgb: tuple[int, int, int]) -> int:
    """An opaque colour as rerun stores it: 0xRRGGBBAA."""
    return int.from_bytes(bytes([*rgb, 255]), "big")


def write_map(folder: Path, safe: bool) -> trimesh.Trimesh:
    """A map as `map_vessels` writes one: an artery surface (PLY, mm, base frame), no vein,
    and a needle in vessels.json."""
    folder.mkdir()
    artery = trimesh.creation.box(extents=(10.0, 4.0, 4.0))
    artery.apply_translation((-300.0, -130.0, 40.0))
    artery.export(folder / "artery.ply")
    needle = {"safe": safe, "entry_mm": ENTRY_MM, "target_mm": TARGET_MM}
    (folder / "vessels.json").write_text(json.dumps({"needle": needle}))
    return artery


def logged_map(folder: Path, path: Path) -> tuple[list[str], Recording]:
    with open_recording("test", save=path) as session:
        logged = log_vessel_map(session.stream, folder, "left")
    return logged, Recording(path)


def test_surfaces_and_a_safe_needle_are_logged_in_metres(tmp_path):
    artery = write_map(tmp_path / "map", safe=True)
    logged, recording = logged_map(tmp_path / "map", tmp_path / "map.rrd")
    assert logged == ["world/vessel_map/left/artery", "world/vessel_map/left/needle"]
    surface = recording.static["/world/vessel_map/left/artery"]
    positions = np.array(surface["Mesh3D:vertex_positions"])
    np.testing.assert_allclose(positions, artery.vertices * 1e-3, atol=1e-7)
    np.testing.assert_array_equal(surface["Mesh3D:triangle_indices"], artery.faces)
    assert surface["Mesh3D:albedo_factor"] == [packed(label_colour(ARTERY))]
    needle = recording.static["/world/vessel_map/left/needle"]
    np.testing.assert_allclose(
        needle["LineStrips3D:strips"], [[np.array(ENTRY_MM) * 1e-3, np.array(TARGET_MM) * 1e-3]],
        atol=1e-7,
    )  # fmt: skip
    assert needle["LineStrips3D:colors"] == [packed(NEEDLE_COLOUR)]
    assert "/world/vessel_map/left/vein" not in recording.entities  # the map found none


def test_an_unsafe_needle_is_not_drawn(tmp_path):
    write_map(tmp_path / "map", safe=False)
    logged, recording = logged_map(tmp_path / "map", tmp_path / "map.rrd")
    assert logged == ["world/vessel_map/left/artery"]
    assert "/world/vessel_map/left/needle" not in recording.entities
