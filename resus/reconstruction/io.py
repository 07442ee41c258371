"""Volumes on disk: NRRD and MetaImage in millimetres, and PNG pictures of three slices.

Coordinates: the world (robot base) frame's x, y, z in millimetres are written unchanged as
the file's physical coordinates, declared as LPS ("left-posterior-superior") in NRRD. That is
what ITK, MetaImage and PLUS do (PLUS's .mha volumes carry the same numbers), so NRRD and .mha
files of one reconstruction, and PLUS's own volumes, open in 3D Slicer in the same place; Slicer
shows them at RAS = (-x, -y, z). Index order is `[i, j, k]`, the grid's axes, and non-orthogonal
grids (the RANSAC parallelepiped) keep their exact step vectors.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from sim.labels import label_overlay

MM = 1e3
NRRD_SUFFIXES = (".nrrd", ".nhdr")
METAIMAGE_SUFFIXES = (".mha", ".mhd")
LABEL_ALPHA = 0.45
"""Opacity of the label overlay in slice pictures."""


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in NRRD_SUFFIXES + METAIMAGE_SUFFIXES:
        raise ResusError("volume files must end in .nrrd, .nhdr, .mha or .mhd", path)
    return suffix


def write_volume(
    path: str | Path, array: np.ndarray, grid: VolumeGrid, label_names: list[str] | None = None
) -> Path:
    """Write `array` (nx, ny, nz) on `grid` as NRRD or MetaImage (by suffix), in millimetres."""
    path = Path(path)
    suffix = _suffix(path)
    if array.shape != grid.shape:
        raise ResusError(f"volume shape {array.shape} does not match grid {grid.shape}", path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix in NRRD_SUFFIXES:
        import nrrd

        header = {
            "space": "left-posterior-superior",
            "space directions": grid.axes * MM,
            "space origin": grid.origin * MM,
            "kinds": ["domain", "domain", "domain"],
            "encoding": "gzip",
        }
        if label_names:
            header["label_names"] = ",".join(label_names)
        nrrd.write(str(path), np.ascontiguousarray(array), header, index_order="F")
    else:
        import SimpleITK as sitk

        image = sitk.GetImageFromArray(np.ascontiguousarray(array.transpose(2, 1, 0)))
        image.SetSpacing(tuple(grid.spacing * MM))
        image.SetOrigin(tuple(grid.origin * MM))
        image.SetDirection(tuple(grid.directions.T.ravel()))
        if label_names:
            image.SetMetaData("label_names", ",".join(label_names))
        sitk.WriteImage(image, str(path), useCompression=True)
    return path


def read_volume(path: str | Path) -> tuple[np.ndarray, VolumeGrid, list[str] | None]:
    """Read a volume written by `write_volume` (or by PLUS / Slicer): array, grid, label names."""
    path = Path(path)
    suffix = _suffix(path)
    if not path.is_file():
        raise ResusError("no such volume file", path)
    if suffix in NRRD_SUFFIXES:
        import nrrd

        try:
            array, header = nrrd.read(str(path), index_order="F")
        except Exception as error:
            raise ResusError(f"not a readable NRRD volume ({error})", path) from error
        if array.ndim != 3:
            raise ResusError(f"expected a 3D volume, got {array.ndim} dimensions", path)
        axes = (
            np.asarray(
                header.get("space directions", np.diag(header.get("spacings", [1.0] * 3))),
                dtype=float,
            )
            / MM
        )
        origin = np.asarray(header.get("space origin", np.zeros(3)), dtype=float) / MM
        if header.get("space") in ("right-anterior-superior", "RAS"):
            flip = np.array([-1.0, -1.0, 1.0])
            axes, origin = axes * flip, origin * flip
        names = header.get("label_names")
    else:
        import SimpleITK as sitk

        try:
            image = sitk.ReadImage(str(path))
        except RuntimeError as error:
            raise ResusError(f"not a readable MetaImage volume ({error})", path) from error
        if image.GetDimension() != 3:
            raise ResusError(f"expected a 3D volume, got {image.GetDimension()} dimensions", path)
        array = sitk.GetArrayFromImage(image).transpose(2, 1, 0)
        direction = np.array(image.GetDirection()).reshape(3, 3)
        axes = (direction * np.array(image.GetSpacing())).T / MM
        origin = np.array(image.GetOrigin()) / MM
        names = image.GetMetaData("label_names") if image.HasMetaDataKey("label_names") else None
    grid = VolumeGrid(origin=origin, axes=axes, shape=array.shape)
    return np.ascontiguousarray(array), grid, names.split(",") if names else None


def intensity_to_uint8(volume: np.ndarray) -> np.ndarray:
    """Round and clip a float intensity volume to uint8, as B-mode images are stored."""
    return np.clip(np.rint(volume), 0, 255).astype(np.uint8)


def save_slices_png(
    path: str | Path,
    volume: np.ndarray,
    grid: VolumeGrid,
    labels: np.ndarray | None = None,
    centre: tuple[int, int, int] | None = None,
    title: str = "",
) -> Path:
    """PNG of the three index-orthogonal slices through `centre` (default: the middle voxel),
    drawn to scale, with labels as coloured overlays when given."""
    from matplotlib.figure import Figure

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ResusError("slice pictures must end in .png", path)
    centre = centre or (grid.shape[0] // 2, grid.shape[1] // 2, grid.shape[2] // 2)
    spacing = grid.spacing * MM
    views = [(2, 0, 1), (1, 0, 2), (0, 1, 2)]  # (fixed axis, horizontal, vertical)
    figure = Figure(figsize=(15, 5.4))
    panels = figure.subplots(1, 3)
    low, high = np.percentile(volume, [1, 99.5]) if volume.size else (0, 1)
    for panel, (fixed, across, down) in zip(panels, views, strict=True):
        index: list[slice | int] = [slice(None)] * 3
        index[fixed] = centre[fixed]
        image = volume[tuple(index)]  # indexed [across, down]
        extent = (0, grid.shape[across] * spacing[across], grid.shape[down] * spacing[down], 0)
        panel.imshow(image.T, cmap="gray", vmin=low, vmax=max(high, low + 1e-6), extent=extent)
        if labels is not None:
            label_slice = labels[tuple(index)].T
            panel.imshow(label_overlay(label_slice, LABEL_ALPHA), extent=extent)
        name = "ijk"
        panel.set_title(f"{name[fixed]} = {centre[fixed]}")
        panel.set_xlabel(f"{name[across]} (mm)")
        panel.set_ylabel(f"{name[down]} (mm)")
    figure.suptitle(title or "reconstructed volume: three orthogonal slices")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)
    return path
