"""Stage 1-2: the voxel grid of a sweep and its squared-distance-weighted compounding.

- `grid`: `VolumeGrid` (origin and step vectors) and the axis-aligned box `aabb_grid`.
- `parallelepiped`: the paper's volume, `ransac_grid`, fitted with RANSAC planes.
- `grid_settings`: `GridSettings`, which of the two grids around a sweep, and its voxels.
- `compounding`: `ReconstructionSettings`, `Reconstructor` and `reconstruct` (SDW, PLUS's
  nearest-neighbour and trilinear insertion, hole filling, label channels).
- `kernels`: the numba kernels that insert frames and fill holes.
- `live`: a volume that grows while a scan runs, logged to rerun.
- `io`: NRRD and MetaImage volumes in millimetres.
- `figures`: PNG pictures of three orthogonal slices with labels.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
compounding: ReconstructedVolume ReconstructionSettings Reconstructor reconstruct
grid: VolumeGrid aabb_grid frame_points_world
grid_settings: GRIDS GridSettings
io: intensity_to_uint8 read_label_volume read_volume write_volume
figures: save_slices_png
live: LiveVolume planned_grid
parallelepiped: ransac_grid
""",
)
