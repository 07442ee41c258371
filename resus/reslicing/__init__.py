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

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
dataset: ResliceDataset ResliceWriter
plane: ObliquePlane reslice_plane
reslice: Reslice ResliceSettings reslice_volume
sheet: save_contact_sheet
""",
)
