"""Stage 1-2: the voxel grid of a sweep and its squared-distance-weighted compounding.

- `grid`: `VolumeGrid` (origin and step vectors) and the axis-aligned box `aabb_grid`.
- `ransac_grid`: the paper's parallelepiped fitted with RANSAC planes.
- `compounding`: `ReconstructionSettings`, `Reconstructor` and `reconstruct` (SDW, PLUS's
  nearest-neighbour and trilinear insertion, hole filling, label channels).
- `kernels`: the numba kernels that insert frames and fill holes.
- `live`: a volume that grows while a scan runs, logged to rerun.
- `io`: NRRD and MetaImage volumes in millimetres; PNG pictures of three slices.
"""

from resus import lazy_exports

_EXPORTS = {
    "VolumeGrid": "resus.reconstruction.grid",
    "aabb_grid": "resus.reconstruction.grid",
    "frame_points_world": "resus.reconstruction.grid",
    "ransac_grid": "resus.reconstruction.ransac_grid",
    "ReconstructionSettings": "resus.reconstruction.compounding",
    "ReconstructedVolume": "resus.reconstruction.compounding",
    "Reconstructor": "resus.reconstruction.compounding",
    "reconstruct": "resus.reconstruction.compounding",
    "LiveVolume": "resus.reconstruction.live",
    "planned_grid": "resus.reconstruction.live",
    "read_volume": "resus.reconstruction.io",
    "write_volume": "resus.reconstruction.io",
    "intensity_to_uint8": "resus.reconstruction.io",
    "save_slices_png": "resus.reconstruction.io",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
