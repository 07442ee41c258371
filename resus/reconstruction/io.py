"""Volumes on disk: NRRD and MetaImage in millimetres.

Coordinates: the world (robot base) frame's x, y, z in millimetres are written unchanged as
the file's physical coordinates, declared as LPS ("left-posterior-superior") in NRRD. That is
what ITK, MetaImage and PLUS do (PLUS's .mha volumes carry the same numbers), so NRRD and .mha
files of one reconstruction, and PLUS's own volumes, open in 3D Slicer in the same place; Slicer
shows them at RAS = (-x, -y, z). Index order is `[i, j, k]`, the grid's axes, and non-orthogonal
grids (the RANSAC parallelepiped) keep their exact step vectors.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from resus.sweep.io import error_summary
from resus.sweep.timestamps import now

MM = 1e3
NRRD_SUFFIXES = (".nrrd", ".nhdr")
METAIMAGE_SUFFIXES = (".mha", ".mhd")
SUBJECT_FIELD = "resus_subject"
"""Header field of the subject whose sweep a volume was reconstructed from."""


def volume_suffix(path: Path) -> str:
    """The volume format of `path` by its suffix (lower case); any other suffix is a
    ResusError naming the file (callers check before the work whose result it would hold)."""
    suffix = Path(path).suffix.lower()
    if suffix not in NRRD_SUFFIXES + METAIMAGE_SUFFIXES:
        raise ResusError("volume files must end in .nrrd, .nhdr, .mha or .mhd", path)
    return suffix


def _existing_volume(path: str | Path) -> tuple[Path, str]:
    """`path` and its volume suffix; ResusError if it is no volume file name or no file."""
    path = Path(path)
    suffix = volume_suffix(path)
    if not path.is_file():
        raise ResusError("no such volume file", path)
    return path, suffix


def write_volume(
    path: str | Path,
    array: np.ndarray,
    grid: VolumeGrid,
    label_names: Sequence[str] | None = None,
    subject: str | None = None,
) -> Path:
    """Write `array` (nx, ny, nz) on `grid` as NRRD or MetaImage (by suffix), in millimetres.

    `label_names` and the `subject` of the sweep it was reconstructed from are kept as header
    fields (`label_names`, `resus_subject`), so that reslices of the volume know their subject.
    """
    path = Path(path)
    suffix = volume_suffix(path)
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
        if subject:
            header[SUBJECT_FIELD] = subject
        nrrd.write(str(path), np.ascontiguousarray(array), header, index_order="F")
        _stamp_nrrd(path)
    else:
        import SimpleITK as sitk

        image = sitk.GetImageFromArray(np.ascontiguousarray(array.transpose(2, 1, 0)))
        image.SetSpacing(tuple(grid.spacing * MM))
        image.SetOrigin(tuple(grid.origin * MM))
        image.SetDirection(tuple(grid.directions.T.ravel()))
        if label_names:
            image.SetMetaData("label_names", ",".join(label_names))
        if subject:
            image.SetMetaData(SUBJECT_FIELD, subject)
        sitk.WriteImage(image, str(path), useCompression=True)
    return path


NRRD_TIME_LINE = re.compile(rb"# on \d{4}-\d\d-\d\d \d\d:\d\d:\d\d\(GMT\)\.\n")
"""The comment pynrrd writes its clock's time in (always, as the file's third line)."""


def _stamp_nrrd(path: Path) -> None:
    """Put `resus.sweep.timestamps.now()` in the time comment pynrrd wrote, in place (same
    length): with SOURCE_DATE_EPOCH set, two runs write byte-identical volumes."""
    with open(path, "r+b") as file:
        head = file.read(256)
        found = NRRD_TIME_LINE.search(head)
        if found is None:
            return  # a pynrrd that writes no time: nothing to stamp
        file.seek(found.start())
        file.write(now().strftime("# on %Y-%m-%d %H:%M:%S(GMT).\n").encode("ascii"))


def read_volume(path: str | Path) -> tuple[np.ndarray, VolumeGrid, list[str] | None]:
    """Read a volume written by `write_volume` (or by PLUS / Slicer): array, grid, label names."""
    path, suffix = _existing_volume(path)
    if suffix in NRRD_SUFFIXES:
        import nrrd

        try:
            array, header = nrrd.read(str(path), index_order="F")
        except Exception as error:
            raise ResusError(f"not a readable NRRD volume ({error_summary(error)})", path) from None
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
            raise ResusError(
                f"not a readable MetaImage volume ({error_summary(error)})", path
            ) from None
        if image.GetDimension() != 3:
            raise ResusError(f"expected a 3D volume, got {image.GetDimension()} dimensions", path)
        array = sitk.GetArrayFromImage(image).transpose(2, 1, 0)
        direction = np.array(image.GetDirection()).reshape(3, 3)
        axes = (direction * np.array(image.GetSpacing())).T / MM
        origin = np.array(image.GetOrigin()) / MM
        names = image.GetMetaData("label_names") if image.HasMetaDataKey("label_names") else None
    grid = VolumeGrid(origin=origin, axes=axes, shape=array.shape)
    return np.ascontiguousarray(array), grid, names.split(",") if names else None


def read_label_volume(path: str | Path, grid: VolumeGrid) -> tuple[np.ndarray, list[str] | None]:
    """The label volume at `path` (classes, label names), checked to lie on `grid`, the grid
    of the intensity volume it labels."""
    labels, label_grid, names = read_volume(path)
    if label_grid.shape != grid.shape:
        raise ResusError(
            f"labels shape {label_grid.shape} differs from the volume's {grid.shape}", path
        )
    if not grid.places_like(label_grid):
        raise ResusError("label volume is not on the volume's grid (origin or axes differ)", path)
    return labels, names


def volume_subject(path: str | Path) -> str | None:
    """The subject of the sweep a volume was reconstructed from, if its header records one
    (the header alone is read)."""
    path, suffix = _existing_volume(path)
    if suffix in NRRD_SUFFIXES:
        import nrrd

        try:
            return nrrd.read_header(str(path)).get(SUBJECT_FIELD) or None
        except Exception as error:  # pynrrd raises several kinds for a file that is not NRRD
            raise ResusError(f"not a readable NRRD volume ({error_summary(error)})", path) from None
    import SimpleITK as sitk

    reader = sitk.ImageFileReader()
    reader.SetFileName(str(path))
    try:
        reader.ReadImageInformation()
    except RuntimeError as error:
        summary = error_summary(error)
        raise ResusError(f"not a readable MetaImage volume ({summary})", path) from None
    return reader.GetMetaData(SUBJECT_FIELD) if reader.HasMetaDataKey(SUBJECT_FIELD) else None


def intensity_to_uint8(volume: np.ndarray) -> np.ndarray:
    """Round and clip a float intensity volume to uint8, as B-mode images are stored."""
    return np.clip(np.rint(volume), 0, 255).astype(np.uint8)
