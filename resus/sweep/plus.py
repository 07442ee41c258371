"""PLUS MetaImage sequences (`.igs.mha`) in and out of Sweeps.

PLUS (the open toolkit for tracked ultrasound) stores a sweep as one 3D MetaImage whose
slices are the frames, with per-frame header fields `Seq_Frame0000_ProbeToTrackerTransform`
(16 numbers, row-major, millimetres), `..._Timestamp`, `..._ImageStatus` and a `...Status`
per transform. The image-to-probe calibration lives in a separate PLUS config XML.
SimpleITK reads and writes all of these header fields.

The world frame of an imported sweep is PLUS's Reference frame:
`probe_to_base = inv(ReferenceToTracker) @ ProbeToTracker` (or `ProbeToReference` where the
file has it). Lengths are millimetres in the files and metres in the Sweep. Tracker poses in
PLUS files carry about six significant digits, so some rotations are not orthonormal to
the Sweep's 1e-6 tolerance: the importer projects those onto the nearest rotation (a change
of about 1e-6, far below tracking error) after checking they are rigid to 1e-3.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from resus.sweep.io import error_summary, file_errors
from resus.sweep.model import Sweep, SweepError, check_calibration
from sim.transforms import is_rigid, rigidity_error

MM_PER_M = 1000.0
CALIBRATION_FIELD = "ImageToProbeTransform"
"""Custom header field in exported sequences: image-to-probe in millimetres, like PLUS XML."""
IMPORT_RIGID_TOLERANCE = 1e-3
SUPPORTED_ORIENTATIONS = ("MF", "MFA")
META_ELEMENT_BYTES = {
    "MET_UCHAR": 1,
    "MET_CHAR": 1,
    "MET_USHORT": 2,
    "MET_SHORT": 2,
    "MET_UINT": 4,
    "MET_INT": 4,
    "MET_FLOAT": 4,
    "MET_DOUBLE": 8,
}


def _frame_field(index: int, name: str) -> str:
    return f"Seq_Frame{index:04d}_{name}"


def _matrix_text(matrix: np.ndarray) -> str:
    """16 numbers, row-major, each written so that it reads back exactly."""
    return " ".join(repr(float(value)) for value in np.asarray(matrix).ravel())


def _parse_matrix(text: str | None, what: str) -> np.ndarray:
    try:
        values = np.array((text or "").split(), dtype=np.float64)
    except ValueError:
        raise SweepError(f"{what} is not 16 numbers: {text!r}") from None
    if values.shape != (16,) or not np.isfinite(values).all():
        raise SweepError(f"{what} is not 16 finite numbers: {text!r}")
    return values.reshape(4, 4)


def to_mm(matrix: np.ndarray) -> np.ndarray:
    """A 4x4 map from pixels to metres (rotation and scale included) as a map to millimetres."""
    matrix = np.array(matrix, dtype=np.float64)
    matrix[:3] *= MM_PER_M
    return matrix


def from_mm(matrix: np.ndarray) -> np.ndarray:
    """The inverse of `to_mm`: a map from pixels to millimetres as a map to metres."""
    matrix = np.array(matrix, dtype=np.float64)
    matrix[:3] /= MM_PER_M
    return matrix


def _nearest_rigid(pose_mm: np.ndarray, what: str) -> np.ndarray:
    """A tracked pose (millimetres) in metres, its rotation projected onto the nearest proper
    rotation where it is not rigid to the Sweep's tolerance (and refused if far from it)."""
    error = float(rigidity_error(pose_mm))
    if error > IMPORT_RIGID_TOLERANCE:
        raise SweepError(f"{what} is not a rigid transform (error {error:.1e})")
    pose = np.array(pose_mm, dtype=np.float64)
    pose[:3, 3] /= MM_PER_M
    if not is_rigid(pose):
        u, _, vt = np.linalg.svd(pose[:3, :3])
        pose[:3, :3] = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        pose[3] = (0.0, 0.0, 0.0, 1.0)
    return pose


def read_plus_calibration(config_xml: str | Path) -> np.ndarray:
    """Image-to-probe (metres per pixel included) from the Image/Probe transform of a PLUS
    config XML's `CoordinateDefinitions` (a Probe-to-Image transform is inverted)."""
    path = Path(config_xml)
    if not path.is_file():
        raise SweepError("no such file", path)
    with file_errors(path, "reading the PLUS config"):
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as error:
            raise SweepError(f"not a PLUS config XML ({error})") from None
        for transform in root.iter("Transform"):
            ends = (transform.get("From"), transform.get("To"))
            if ends in (("Image", "Probe"), ("Probe", "Image")):
                matrix = _parse_matrix(transform.get("Matrix"), f"{ends[0]}To{ends[1]} Matrix")
                if ends == ("Probe", "Image"):
                    matrix = np.linalg.inv(check_calibration(matrix))
                return check_calibration(from_mm(matrix))
        raise SweepError('has no <Transform From="Image" To="Probe"> (the calibration)')


def write_plus_calibration(image_to_probe: np.ndarray, config_xml: str | Path) -> None:
    """A minimal PLUS config XML holding the Image-to-Probe calibration (millimetres)."""
    path = Path(config_xml)
    matrix = _matrix_text(to_mm(check_calibration(image_to_probe)))
    text = (
        '<PlusConfiguration version="2.1">\n'
        "  <CoordinateDefinitions>\n"
        f'    <Transform From="Image" To="Probe" Matrix={quoteattr(matrix)} />\n'
        "  </CoordinateDefinitions>\n"
        "</PlusConfiguration>\n"
    )
    with file_errors(path, "writing the PLUS config"):
        path.write_text(text)


def _check_metaimage_file(path: Path) -> None:
    """The header is MetaImage text and, for pixels inside the file (ElementDataFile =
    LOCAL), all the bytes it promises follow it.

    ITK reports a wrong or cut file only as "cannot be read" and prints its own lines to
    stderr, so these two common problems are found here first, with a clear message.
    """
    with open(path, "rb") as file:
        head = file.read(1 << 20)
    match = re.search(rb"^ElementDataFile *= *([^\r\n]*)\r?\n", head, re.MULTILINE)
    if not head.startswith((b"ObjectType", b"NDims")) or match is None:
        raise SweepError("not a MetaImage (no 'ObjectType ... ElementDataFile' text header)")
    lines = head[: match.start()].decode("latin-1").splitlines()
    fields = {key.strip(): value.strip() for key, _, value in (ln.partition("=") for ln in lines)}
    if match.group(1).strip() != b"LOCAL":
        return
    if fields.get("CompressedData", "").lower() == "true" and "CompressedDataSize" in fields:
        expected = int(fields["CompressedDataSize"])
    elif fields.get("ElementType") in META_ELEMENT_BYTES and "DimSize" in fields:
        expected = META_ELEMENT_BYTES[fields["ElementType"]] * int(
            np.prod([int(n) for n in fields["DimSize"].split()])
            * int(fields.get("ElementNumberOfChannels", "1"))
        )
    else:
        return
    available = path.stat().st_size - match.end()
    if available < expected:
        raise SweepError(f"MetaImage is truncated ({available} of {expected} bytes of pixels)")


def _read_sequence(path: Path) -> tuple[np.ndarray, dict[str, str]]:
    """Frames (N, H, W) uint8 and the header fields of a MetaImage sequence."""
    import SimpleITK as sitk  # imported here: `import resus.sweep` stays light

    if not path.is_file():
        raise SweepError("no such file", path)
    with file_errors(path, "reading the PLUS sequence"):
        if path.suffix.lower() not in (".mha", ".mhd"):
            raise SweepError("not a MetaImage (.igs.mha) PLUS sequence")
        _check_metaimage_file(path)
        reader = sitk.ImageFileReader()
        reader.SetFileName(str(path))
        reader.SetImageIO("MetaImageIO")
        try:
            image = reader.Execute()
        except RuntimeError as error:
            raise SweepError(f"not a readable MetaImage ({error_summary(error)})") from None
        fields = {key: image.GetMetaData(key) for key in image.GetMetaDataKeys()}
        if image.GetNumberOfComponentsPerPixel() != 1 or image.GetPixelID() != sitk.sitkUInt8:
            raise SweepError(
                f"pixels are {image.GetPixelIDTypeAsString()}; only 8-bit grey frames are supported"
            )
        frames = sitk.GetArrayFromImage(image)
    if frames.ndim == 2:
        frames = frames[None]
    return frames, fields


def import_plus_sequence(
    sequence_path: str | Path,
    calibration: np.ndarray | None = None,
    *,
    subject: str | None = None,
    on_skip: Callable[[int, str], None] | None = None,
) -> Sweep:
    """A Sweep (source 'plus', world = PLUS Reference frame, metres) from a PLUS sequence.

    `calibration` is image-to-probe in metres (`read_plus_calibration`); without it the
    sequence's own `ImageToProbeTransform` field (written by `export_plus_sequence`) is used.
    Frames whose ImageStatus or transform status is not OK are left out; `on_skip(index,
    reason)` hears of each. `subject` defaults to the file name without its suffixes.
    """
    path = Path(sequence_path)
    frames, fields = _read_sequence(path)
    with file_errors(path, "importing the PLUS sequence"):
        if _frame_field(0, "Timestamp") not in fields:
            raise SweepError("not a PLUS sequence (no Seq_Frame0000_Timestamp field)")
        orientation = fields.get("UltrasoundImageOrientation", "MF").strip().upper()
        if orientation not in SUPPORTED_ORIENTATIONS:
            raise SweepError(
                f"UltrasoundImageOrientation is {orientation}; only MF images are supported"
            )
        if calibration is None:
            if CALIBRATION_FIELD not in fields:
                raise SweepError(
                    "has no ImageToProbeTransform field: give the PLUS config XML with the "
                    "Image to Probe calibration"
                )
            calibration = from_mm(_parse_matrix(fields[CALIBRATION_FIELD], CALIBRATION_FIELD))
        kept, poses, timestamps = [], [], []
        for index in range(len(frames)):
            pose = _frame_pose(fields, index)
            if isinstance(pose, str):
                if on_skip is not None:
                    on_skip(index, pose)
                continue
            timestamp = fields.get(_frame_field(index, "Timestamp"))
            if timestamp is None:
                raise SweepError(f"frame {index} has no Timestamp field")
            kept.append(index)
            poses.append(pose)
            timestamps.append(float(timestamp))
        if not kept:
            raise SweepError(f"none of the {len(frames)} frames has an OK status")
        return Sweep(
            frames=frames[kept],
            probe_to_base=np.stack(poses),
            timestamps=np.array(timestamps),
            image_to_probe=calibration,
            source="plus",
            subject=path.name.split(".")[0] if subject is None else subject,
        )


def _frame_pose(fields: dict[str, str], index: int) -> np.ndarray | str:
    """Probe-to-Reference (metres) of frame `index`, or why the frame must be skipped."""

    def status(name: str) -> str:
        return fields.get(_frame_field(index, name), "OK").strip().upper()

    if status("ImageStatus") != "OK":
        return f"ImageStatus {status('ImageStatus')}"
    if _frame_field(index, "ProbeToReferenceTransform") in fields:
        names = ["ProbeToReferenceTransform"]
    elif _frame_field(index, "ProbeToTrackerTransform") in fields:
        names = ["ProbeToTrackerTransform", "ReferenceToTrackerTransform"]
    else:
        raise SweepError(
            f"frame {index} has neither a ProbeToReferenceTransform nor a "
            "ProbeToTrackerTransform field"
        )
    matrices = []
    for name in names:
        if status(f"{name}Status") != "OK":
            return f"{name}Status {status(f'{name}Status')}"
        key = _frame_field(index, name)
        if key not in fields:
            raise SweepError(f"frame {index} has no {name} field")
        matrices.append(_parse_matrix(fields[key], key))
    probe_to_reference = matrices[0]
    if len(matrices) == 2:
        probe_to_reference = np.linalg.inv(matrices[1]) @ matrices[0]
    return _nearest_rigid(probe_to_reference, f"frame {index} {' and '.join(names)}")


def export_plus_sequence(sweep: Sweep, path: str | Path) -> None:
    """Write `sweep` as a PLUS sequence (millimetres, zlib-compressed) that PLUS reads back.

    Each frame gets ProbeToTracker = its pose and an identity ReferenceToTracker (so the
    sweep's world is PLUS's Reference frame), its Timestamp and OK statuses; the calibration
    goes into the `ImageToProbeTransform` header field (`write_plus_calibration` writes it
    as a PLUS config XML). Labels, wrench and joint positions have no place in the format.
    """
    import SimpleITK as sitk  # imported here: `import resus.sweep` stays light

    path = Path(path)
    if not re.search(r"\.mha$", path.name, re.IGNORECASE):
        raise SweepError("a PLUS sequence file name must end in .igs.mha (or .mha)", path)
    with file_errors(path, "writing the PLUS sequence"):
        image = sitk.GetImageFromArray(sweep.frames)
        header = {
            "Kinds": "domain domain list",
            "UltrasoundImageOrientation": "MFA",
            "UltrasoundImageType": "BRIGHTNESS",
            CALIBRATION_FIELD: _matrix_text(to_mm(sweep.image_to_probe)),
        }
        identity = _matrix_text(np.eye(4))
        for index, pose in enumerate(sweep.probe_to_base):
            pose_mm = pose.copy()
            pose_mm[:3, 3] *= MM_PER_M
            header |= {
                _frame_field(index, "ProbeToTrackerTransform"): _matrix_text(pose_mm),
                _frame_field(index, "ProbeToTrackerTransformStatus"): "OK",
                _frame_field(index, "ReferenceToTrackerTransform"): identity,
                _frame_field(index, "ReferenceToTrackerTransformStatus"): "OK",
                _frame_field(index, "Timestamp"): repr(float(sweep.timestamps[index])),
                _frame_field(index, "ImageStatus"): "OK",
            }
        for key, value in header.items():
            image.SetMetaData(key, value)
        sitk.WriteImage(image, str(path), True)
