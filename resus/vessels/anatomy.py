"""Telling the femoral artery from the vein by anatomy, not by the segmentation's class.

In the femoral triangle the artery lies LATERAL to the vein (lateral to medial: nerve,
artery, vein). The scene says which way lateral is: the phantom frame's +x is the patient's
right, so lateral is +x on a right leg and -x on a left leg, carried into the world by
`phantom_to_base`; the leg runs along the phantom's y (+y distal).

The rule, on the connected parts of the vessel mask (both classes together, so merged or
swapped classes do not matter): the two largest parts are the two trunks, and the more
lateral of them (by centroid) is the artery. Every other kept part (a branch the scan cut off
from its trunk, e.g. the deep femoral artery or the great saphenous vein) goes to the artery
if its centroid lies lateral of the midpoint between the trunks, else to the vein: branches
leave the artery laterally (deep femoral) and the vein medially (great saphenous). With a
single part there is nothing to compare, and the segmentation's majority class is kept.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from resus.reconstruction.grid import VolumeGrid
from sim.labels import ARTERY, LABEL_NAMES, VEIN, VESSEL_CLASSES

if TYPE_CHECKING:
    from sim.robot.scene_config import SceneConfig


@dataclass(frozen=True)
class AnatomicalFrame:
    """World (robot base) unit vectors pointing lateral and proximal on the scanned leg."""

    lateral: np.ndarray
    proximal: np.ndarray

    @classmethod
    def from_scene(cls, scene: SceneConfig) -> AnatomicalFrame:
        """Lateral is phantom +x on a right leg, -x on a left one; proximal is phantom -y."""
        rotation = scene.phantom_to_base[:3, :3]
        side = 1.0 if scene.leg_side == "right" else -1.0
        return cls(rotation @ np.array([side, 0.0, 0.0]), rotation @ np.array([0.0, -1.0, 0.0]))


@dataclass
class VesselPart:
    """One connected part of the vessel mask and the class anatomy gives it."""

    index: int
    """Its value in the part-index volume (1-based)."""
    volume: float
    """m^3."""
    centroid: np.ndarray
    """World position (m)."""
    lateral: float
    """Centroid's coordinate along the lateral direction (m)."""
    segmented_votes: dict[str, int]
    """Voxels the segmentation gave each vessel class, by class name."""
    label: int = 0
    """Class given by anatomy (ARTERY or VEIN)."""

    @property
    def segmented_label(self) -> int:
        """The segmentation's majority class in this part."""
        votes = self.segmented_votes
        return ARTERY if votes[LABEL_NAMES[ARTERY]] >= votes[LABEL_NAMES[VEIN]] else VEIN

    def to_dict(self) -> dict:
        """JSON-able form in millimetres, as vessels.json lists the parts."""
        return {
            "volume_mm3": round(self.volume * 1e9, 2),
            "centroid_mm": [round(float(c) * 1e3, 2) for c in self.centroid],
            "lateral_mm": round(self.lateral * 1e3, 2),
            "segmented_votes": self.segmented_votes,
            "label": LABEL_NAMES[self.label],
            "segmented_label": LABEL_NAMES[self.segmented_label],
        }


def find_parts(
    vessel_mask: np.ndarray,
    segmented: np.ndarray,
    grid: VolumeGrid,
    frame: AnatomicalFrame,
    min_volume: float,
) -> tuple[np.ndarray, list[VesselPart]]:
    """Part-index volume (0 = none) of the 6-connected vessel mask, and the parts at least
    `min_volume` m^3 large (smaller specks keep their index but are not listed), largest first."""
    part_index, count = ndimage.label(vessel_mask)
    voxel_volume = abs(float(np.linalg.det(grid.axes)))
    sizes = np.bincount(part_index.ravel(), minlength=count + 1)
    keep = [i for i in range(1, count + 1) if sizes[i] * voxel_volume >= min_volume]
    parts = []
    for index in sorted(keep, key=lambda i: -sizes[i]):
        voxels = np.argwhere(part_index == index)
        centroid = grid.to_world(voxels.mean(axis=0))
        votes = segmented[tuple(voxels.T)]
        parts.append(
            VesselPart(
                index=index,
                volume=sizes[index] * voxel_volume,
                centroid=centroid,
                lateral=float(centroid @ frame.lateral),
                segmented_votes={
                    name: int(np.sum(votes == label)) for name, label in VESSEL_CLASSES.items()
                },
            )
        )
    return part_index, parts


def assign_by_anatomy(parts: list[VesselPart]) -> str:
    """Give every part (largest first) its class by the lateral rule; returns the reasoning."""
    if not parts:
        return "no vessel parts large enough to map"
    if len(parts) == 1:
        parts[0].label = parts[0].segmented_label
        return (
            "one vessel part only: nothing to compare laterally, kept the segmentation's "
            f"majority class ({LABEL_NAMES[parts[0].label]})"
        )
    first, second = parts[0], parts[1]
    artery, vein = (first, second) if first.lateral > second.lateral else (second, first)
    artery.label, vein.label = ARTERY, VEIN
    midline = 0.5 * (artery.lateral + vein.lateral)
    for part in parts[2:]:
        part.label = ARTERY if part.lateral > midline else VEIN
    changed = sum(part.label != part.segmented_label for part in parts)
    return (
        f"the more lateral trunk ({(artery.lateral - vein.lateral) * 1e3:.1f} mm lateral of the "
        f"other) is the artery; {len(parts) - 2} smaller part(s) split at the midline; "
        f"{changed} of {len(parts)} part(s) relabelled against the segmentation"
    )
