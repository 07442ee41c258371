"""Stage 3: views the probe cannot take, cut from a reconstructed volume.

- `reslice`: `ResliceSettings` and `reslice_volume`, the paper's rotate-and-slice procedure and
  its fast plane-sampling path.
- `geometry`: rotations of the voxel array and the poses of oblique slices.
- `sampling`: cubic B-spline intensities and nearest labels on a plane.
- `plane`: arbitrary planes in world coordinates (e.g. along a vessel).
- `dataset`: the `resus.reslices/1` HDF5 dataset that training reads.
- `sheet`: a PNG contact sheet of reslices.
"""

from resus import lazy_exports

_EXPORTS = {
    "Reslice": "resus.reslicing.reslice",
    "ResliceSettings": "resus.reslicing.reslice",
    "reslice_volume": "resus.reslicing.reslice",
    "ObliquePlane": "resus.reslicing.plane",
    "reslice_plane": "resus.reslicing.plane",
    "ResliceDataset": "resus.reslicing.dataset",
    "ResliceWriter": "resus.reslicing.dataset",
    "save_contact_sheet": "resus.reslicing.sheet",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
