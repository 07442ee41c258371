"""ROS bags in and out of Sweeps (rosbags): ROS 1 `.bag`, ROS 2 bags (sqlite3 or MCAP).

Import. `import_ros` reads the images of one topic (`sensor_msgs/msg/Image` or
`CompressedImage`) and the probe's pose from a `geometry_msgs/msg/PoseStamped` topic or from
tf2 (`/tf` and `/tf_static`, the chain PARENT -> CHILD, where CHILD is the probe's TCP frame the
calibration refers to). Each image is placed at its header stamp, and the pose there is
interpolated exactly as the Scanner does it (`sim.transforms.interpolate_poses`: linear in
position, slerp in rotation, between the two samples around the stamp); along a tf chain each
dynamic transform is interpolated at the stamp and the chain multiplied, as tf2's
lookupTransform does. Images whose stamp lies outside the pose stream (before its first or after
its last sample; for tf, outside any dynamic link of the chain) cannot be placed: they are left
out and counted, as are images repeating an earlier stamp. An optional
`geometry_msgs/msg/WrenchStamped` topic becomes the Sweep's wrench, linearly interpolated.

ROS poses are in metres already, like the Sweep. Stamps become seconds as they are
(`sec + nanosec * 1e-9`); interpolation works on integer nanoseconds from the first pose, so
epoch-sized stamps lose no precision.

Image encodings: mono8 (8UC1), mono16 (16UC1), rgb8, bgr8, rgba8, bgra8. Colour is turned to
grey with OpenCV's luma weights. mono16 is scaled to 8 bits by one fixed map, value * 255 /
65535 rounded (divide by 257), so that equal intensities stay equal grey across frames and
bags; per-frame contrast stretching would break compounding. Compressed images (PNG, JPEG) are
decoded by OpenCV and then treated the same way.

The calibration (`image_to_probe`, metres per pixel) comes from a `resus.probe/1` YAML
(`ProbeCalibration`; its crop, if any, is cut from every image) or a PLUS config XML
(`read_plus_calibration`), or is given as a matrix.

Export. `export_ros` writes a ROS 2 bag with MCAP storage that Foxglove opens, and that
`ros2 bag play` replays for RViz: a path ending in `.mcap` is written as that one MCAP file
(rosbag2 keeps its metadata inside it), any other path as a rosbag2 folder. Topics:
`/us/image` (sensor_msgs/msg/Image, mono8, frame_id `probe_image`), `/tf` (base -> probe, the
TCP, one transform per frame, stamped like its image), `/tf_static` (probe -> probe_image,
transient-local so late subscribers get it) and `/us/wrench` (geometry_msgs/msg/WrenchStamped
in the base frame, as UR reports it) when the Sweep has a wrench. The static probe ->
probe_image transform is the rigid part of the calibration (origin at pixel (0, 0), x along
the columns, y along the rows), for display: a tf cannot hold the pixel size, so the
calibration file travels beside the bag (`resus sweep export-ros` writes it).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import Sweep, SweepError, check_calibration
from sim.transforms import interpolate_poses, invert_pose, quaternions_to_matrices

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
POSE_TYPE = "geometry_msgs/msg/PoseStamped"
TF_TYPE = "tf2_msgs/msg/TFMessage"
WRENCH_TYPE = "geometry_msgs/msg/WrenchStamped"
TF_TOPICS = ("/tf", "/tf_static")
ENCODINGS = ("mono8", "mono16", "rgb8", "bgr8", "rgba8", "bgra8")
ENCODING_ALIASES = {"8uc1": "mono8", "16uc1": "mono16"}
EXPORT_IMAGE_TOPIC = "/us/image"
EXPORT_WRENCH_TOPIC = "/us/wrench"
BASE_FRAME, PROBE_FRAME, IMAGE_FRAME = "base", "probe", "probe_image"
NS = 1_000_000_000


@dataclass(frozen=True)
class RosImport:
    """An imported Sweep and how many messages went into it."""

    sweep: Sweep
    images: int
    """Image messages on the topic."""
    outside_poses: int
    """Images left out: stamped outside the pose stream."""
    repeated_stamps: int
    """Images left out: the same stamp as an earlier image."""
    poses: int
    """Pose samples read (PoseStamped messages, or dynamic tf transforms along the chain)."""
    pose_span: tuple[float, float]
    """First and last time (s) the pose stream covers."""


# -- reading bags ---------------------------------------------------------------------------


def _stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * NS + int(header.stamp.nanosec)


def _read_lone_mcap(path: Path, topics: set[str]) -> tuple[dict[str, str], dict[str, list[Any]]]:
    """A single MCAP file (no metadata.yaml beside it, so rosbags' AnyReader cannot open
    it): read with rosbags' MCAP storage reader, typed from the file's own schemas."""
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.rosbag2.storage_mcap import McapReader
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    reader = McapReader(path)
    reader.open()
    try:
        typestore = get_typestore(Stores.ROS2_HUMBLE)
        definitions: dict = {}
        for connection in reader.connections:
            definition = connection.msgdef
            if definition.format == MessageDefinitionFormat.MSG:
                definitions.update(get_types_from_msg(definition.data, connection.msgtype))
            elif definition.format == MessageDefinitionFormat.IDL:
                definitions.update(get_types_from_idl(definition.data))
        typestore.register(definitions)
        types = {c.topic: c.msgtype for c in reader.connections}
        messages: dict[str, list[Any]] = {topic: [] for topic in topics}
        wanted = [c for c in reader.connections if c.topic in topics]
        for connection, _, raw in reader.messages(wanted):
            message = typestore.deserialize_cdr(raw, connection.msgtype)
            messages[connection.topic].append(message)
        return types, messages
    finally:
        reader.close()


def _read_bag(path: Path, topics: set[str]) -> tuple[dict[str, str], dict[str, list[Any]]]:
    """Every bag topic's type, and the messages of `topics` in bag order."""
    from rosbags.highlevel import AnyReader

    if path.is_file() and path.suffix == ".mcap":
        return _read_lone_mcap(path, topics)
    messages: dict[str, list[Any]] = {topic: [] for topic in topics}
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        wanted = [c for c in reader.connections if c.topic in topics]
        for connection, _, raw in reader.messages(connections=wanted):
            messages[connection.topic].append(reader.deserialize(raw, connection.msgtype))
    return types, messages


def _open_errors(path: Path, topics: set[str]) -> tuple[dict[str, str], dict[str, list[Any]]]:
    """`_read_bag` with every failure as one line naming the bag."""
    if not path.exists():
        raise SweepError("no such file or folder", path)
    looks_like = path.suffix in (".bag", ".mcap") or (path / "metadata.yaml").is_file()
    if not looks_like:
        raise SweepError(
            "not a ROS bag (a ROS 1 .bag file, a ROS 2 bag folder with metadata.yaml, or an "
            ".mcap file)",
            path,
        )
    try:
        return _read_bag(path, topics)
    except SweepError:
        raise
    except Exception as error:  # rosbags' reader, serde and type errors
        line = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise SweepError(f"cannot read the bag ({line})", path) from None


# -- images ---------------------------------------------------------------------------------


def _scale_16bit(image: np.ndarray) -> np.ndarray:
    """16-bit intensities to 8 bits: value * 255 / 65535, rounded (one map for every frame)."""
    return ((image.astype(np.uint32) + 128) // 257).astype(np.uint8)


def _grey(image: np.ndarray, colour_order: str) -> np.ndarray:
    """(H, W) uint8 from an 8- or 16-bit grey, RGB(A) or BGR(A) array (the video probe's
    `to_grey` does the colour conversion)."""
    from resus.sweep.images import to_grey

    if image.dtype == np.uint16:
        image = _scale_16bit(image)
    channels = 1 if image.ndim == 2 else image.shape[2] if image.ndim == 3 else 0
    if image.dtype != np.uint8 or channels not in (1, 3, 4):
        raise ResusError(f"{image.dtype} image of shape {image.shape} is neither grey nor colour")
    return np.ascontiguousarray(to_grey(np.ascontiguousarray(image), colour_order))


def image_message_to_grey(message: Any, msgtype: str) -> np.ndarray:
    """The 8-bit grey frame of a sensor_msgs Image or CompressedImage message."""
    import cv2

    data = np.frombuffer(bytes(message.data), np.uint8)
    if msgtype.endswith("CompressedImage"):
        decoded = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
        if decoded is None:
            raise ResusError(f"compressed image ({message.format!r}) cannot be decoded")
        return _grey(decoded, "bgr")  # OpenCV decodes colour as BGR
    encoding = ENCODING_ALIASES.get(message.encoding.lower(), message.encoding.lower())
    if encoding not in ENCODINGS:
        raise ResusError(
            f"image encoding {message.encoding!r} is not supported ({', '.join(ENCODINGS)})"
        )
    height, width, step = int(message.height), int(message.width), int(message.step)
    channels = {"mono8": 1, "mono16": 2, "rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}[encoding]
    if step < width * channels or len(data) < height * step:
        raise ResusError(
            f"{encoding} image {width} x {height} with step {step} holds only {len(data)} bytes"
        )
    rows = data[: height * step].reshape(height, step)[:, : width * channels]
    if encoding == "mono16":
        order = ">" if message.is_bigendian else "<"
        return _scale_16bit(np.ascontiguousarray(rows).view(f"{order}u2").reshape(height, width))
    pixels = rows.reshape(height, width, channels) if channels > 1 else rows
    return np.ascontiguousarray(_grey(pixels, encoding[:3]))


# -- poses ----------------------------------------------------------------------------------


def _pose_matrix(position: Any, orientation: Any) -> np.ndarray:
    """A 4x4 pose from ROS Point/Vector3 and Quaternion fields."""
    quaternion = np.array([orientation.x, orientation.y, orientation.z, orientation.w], float)
    norm = np.linalg.norm(quaternion)
    if not norm > 0:
        raise ResusError("a pose has a zero quaternion")
    pose = np.eye(4)
    pose[:3, :3] = quaternions_to_matrices((quaternion / norm)[None])[0]
    pose[:3, 3] = (position.x, position.y, position.z)
    return pose


@dataclass
class _Series:
    """Poses at increasing integer-nanosecond stamps (repeats of a stamp dropped)."""

    stamps: np.ndarray
    poses: np.ndarray

    @classmethod
    def of(cls, samples: list[tuple[int, np.ndarray]]) -> _Series:
        samples = sorted(samples, key=lambda sample: sample[0])
        kept = [s for i, s in enumerate(samples) if i == 0 or s[0] != samples[i - 1][0]]
        return cls(np.array([s[0] for s in kept], np.int64), np.stack([s[1] for s in kept]))

    def at(self, stamps: np.ndarray, origin: int) -> np.ndarray:
        """Interpolated poses (the scanner's interpolation) at integer-ns `stamps`."""
        if len(self.stamps) == 1:
            return np.repeat(self.poses, len(stamps), axis=0)
        return interpolate_poses(
            (self.stamps - origin) * 1e-9, self.poses, (stamps - origin) * 1e-9
        )


class _TfTree:
    """tf2's frame tree from TFMessages: each frame's parent and its dynamic or static pose."""

    def __init__(self, dynamic: list[Any], static: list[Any]) -> None:
        self.parent: dict[str, str] = {}
        self.samples: dict[str, list[tuple[int, np.ndarray]]] = {}
        self.static: dict[str, np.ndarray] = {}
        for messages, is_static in ((static, True), (dynamic, False)):
            for message in messages:
                for transform in message.transforms:
                    child = transform.child_frame_id.lstrip("/")
                    self.parent[child] = transform.header.frame_id.lstrip("/")
                    t = transform.transform
                    pose = _pose_matrix(t.translation, t.rotation)
                    if is_static:
                        self.static[child] = pose
                    else:
                        self.samples.setdefault(child, []).append(
                            (_stamp_ns(transform.header), pose)
                        )

    def _to_root(self, frame: str) -> list[str]:
        path = [frame]
        while path[-1] in self.parent and len(path) <= len(self.parent):
            path.append(self.parent[path[-1]])
        return path

    def chain(self, parent: str, child: str) -> tuple[list[str], list[str]]:
        """The frames whose poses lead from the common ancestor down to `parent` and to
        `child` (each list ordered from the child end up)."""
        up_child, up_parent = self._to_root(child), self._to_root(parent)
        common = next((frame for frame in up_child if frame in up_parent), None)
        if common is None:
            known = ", ".join(sorted(set(self.parent) | set(self.parent.values()))) or "none"
            raise ResusError(f"tf has no chain from {parent!r} to {child!r} (frames: {known})")
        return up_parent[: up_parent.index(common)], up_child[: up_child.index(common)]

    def series(self, frame: str) -> _Series:
        if frame in self.samples:
            return _Series.of(self.samples[frame])
        return _Series(np.zeros(1, np.int64), self.static[frame][None])


def _compose(tree: _TfTree, frames: list[str], stamps: np.ndarray, origin: int) -> np.ndarray:
    """ancestor_T_frames[0] at each stamp: the poses along the chain multiplied."""
    result = np.repeat(np.eye(4)[None], len(stamps), axis=0)
    for frame in reversed(frames):  # from the ancestor's end down
        result = result @ tree.series(frame).at(stamps, origin)
    return result


# -- import ---------------------------------------------------------------------------------


def _calibration(
    calibration: np.ndarray | str | Path, shape: tuple[int, int]
) -> tuple[np.ndarray, tuple[int, int, int, int] | None]:
    """image_to_probe for images of `shape` after the crop, and the crop rectangle."""
    if not isinstance(calibration, str | Path):
        return check_calibration(calibration), None
    path = Path(calibration)
    if path.suffix.lower() == ".xml":
        from resus.sweep.plus import read_plus_calibration

        return read_plus_calibration(path), None
    from resus.acquisition.calibration.probe import ProbeCalibration

    probe = ProbeCalibration.from_yaml(path)
    crop = probe.crop
    if crop is not None:
        x, y, width, height = crop
        if x + width > shape[1] or y + height > shape[0]:
            raise ResusError(
                f"crop {crop} (x, y, width, height) reaches outside the bag's "
                f"{shape[1]} x {shape[0]} images",
                path,
            )
        shape = (height, width)
    return probe.image_to_probe(shape), crop


def _check_topic(types: dict[str, str], topic: str, allowed: tuple[str, ...], what: str) -> str:
    if topic not in types:
        listed = ", ".join(f"{name} ({kind})" for name, kind in sorted(types.items())) or "none"
        raise ResusError(f"no {what} topic {topic!r} in the bag (topics: {listed})")
    if types[topic] not in allowed:
        raise ResusError(
            f"{what} topic {topic!r} is {types[topic]}, expected {' or '.join(allowed)}"
        )
    return types[topic]


def import_ros(
    bag: str | Path,
    image_topic: str,
    pose_topic: str | None = None,
    tf: tuple[str, str] | None = None,
    calibration: np.ndarray | str | Path | None = None,
    *,
    wrench_topic: str | None = None,
    subject: str | None = None,
    source: str = "real",
) -> RosImport:
    """A Sweep from the images on `image_topic` placed by `pose_topic` (PoseStamped) or by
    the tf chain `tf = (parent, child)`; `calibration` is a resus.probe/1 YAML, a PLUS config
    XML or an image_to_probe matrix (metres). Any problem is one line naming the bag."""
    path = Path(bag)
    if (pose_topic is None) == (tf is None):
        raise ResusError("give exactly one pose source: a PoseStamped topic or a tf PARENT CHILD")
    if calibration is None:
        raise ResusError("a calibration is needed (resus.probe/1 YAML or PLUS config XML)")
    wanted = {image_topic, *([pose_topic] if pose_topic else TF_TOPICS)}
    if wrench_topic:
        wanted.add(wrench_topic)
    types, messages = _open_errors(path, wanted)
    try:
        image_type = _check_topic(types, image_topic, IMAGE_TYPES, "image")
        images = [(_stamp_ns(m.header), m) for m in messages[image_topic]]
        if not images:
            raise ResusError(f"image topic {image_topic!r} holds no messages")
        # the pose source: one series (PoseStamped) or a tf chain
        if pose_topic is not None:
            _check_topic(types, pose_topic, (POSE_TYPE,), "pose")
            samples = [
                (_stamp_ns(m.header), _pose_matrix(m.pose.position, m.pose.orientation))
                for m in messages[pose_topic]
            ]
            if not samples:
                raise ResusError(f"pose topic {pose_topic!r} holds no messages")
            series = _Series.of(samples)
            spans = [(int(series.stamps[0]), int(series.stamps[-1]))]
            pose_count = len(samples)
        else:
            assert tf is not None
            for topic in TF_TOPICS:
                if topic in types:
                    _check_topic(types, topic, (TF_TYPE,), "tf")
            tree = _TfTree(messages["/tf"], messages["/tf_static"])
            up_parent, up_child = tree.chain(*tf)
            dynamic = [f for f in (*up_parent, *up_child) if f in tree.samples]
            spans = [
                (int(tree.series(f).stamps[0]), int(tree.series(f).stamps[-1])) for f in dynamic
            ]
            pose_count = sum(len(tree.samples[f]) for f in dynamic)
        low = max((span[0] for span in spans), default=min(s for s, _ in images))
        high = min((span[1] for span in spans), default=max(s for s, _ in images))
        # the images: in stamp order, once per stamp, inside the pose stream
        images.sort(key=lambda image: image[0])
        unique = [im for i, im in enumerate(images) if i == 0 or im[0] != images[i - 1][0]]
        inside = [im for im in unique if low <= im[0] <= high]
        if not inside:
            raise ResusError(
                f"none of the {len(images)} images lies within the pose stream "
                f"({low * 1e-9:.3f} .. {high * 1e-9:.3f} s)"
            )
        stamps = np.array([s for s, _ in inside], np.int64)
        origin = int(stamps[0])
        if pose_topic is not None:
            poses = series.at(stamps, origin)
        else:
            poses = invert_pose(_compose(tree, up_parent, stamps, origin)) @ _compose(
                tree, up_child, stamps, origin
            )
        frames = [image_message_to_grey(m, image_type) for _, m in inside]
        shapes = {frame.shape for frame in frames}
        if len(shapes) > 1:
            raise ResusError(f"images change size within the topic: {sorted(shapes)}")
        image_to_probe, crop = _calibration(calibration, frames[0].shape)
        stack = np.stack(frames)
        if crop is not None:
            x, y, width, height = crop
            stack = np.ascontiguousarray(stack[:, y : y + height, x : x + width])
        wrench = None
        if wrench_topic:
            wrench = _wrench(types, messages[wrench_topic], wrench_topic, stamps)
        sweep = Sweep(
            frames=stack,
            probe_to_base=poses,
            timestamps=stamps * 1e-9,
            image_to_probe=image_to_probe,
            wrench=wrench,
            source=source,
            subject=path.name.split(".")[0] if subject is None else subject,
        )
    except ResusError as error:
        if error.path is not None:
            raise
        raise SweepError(str(error), path) from None
    return RosImport(
        sweep=sweep,
        images=len(images),
        outside_poses=len(unique) - len(inside),
        repeated_stamps=len(images) - len(unique),
        poses=pose_count,
        pose_span=(low * 1e-9, high * 1e-9),
    )


def _wrench(types: dict[str, str], messages: list[Any], topic: str, stamps: np.ndarray):
    """(N, 6) force and torque at the image stamps, linearly interpolated (clamped at the ends)."""
    _check_topic(types, topic, (WRENCH_TYPE,), "wrench")
    if not messages:
        raise ResusError(f"wrench topic {topic!r} holds no messages")
    samples = sorted(
        (
            _stamp_ns(m.header),
            [
                getattr(getattr(m.wrench, part), axis)
                for part in ("force", "torque")
                for axis in "xyz"
            ],
        )
        for m in messages
    )
    times = np.array([s for s, _ in samples], np.int64)
    values = np.array([v for _, v in samples], float)
    origin = int(times[0])
    query = (stamps - origin) * 1e-9
    return np.stack(
        [np.interp(query, (times - origin) * 1e-9, values[:, k]) for k in range(6)], axis=1
    )


# -- export ---------------------------------------------------------------------------------


def image_frame_pose(image_to_probe: np.ndarray) -> np.ndarray:
    """The rigid part of a calibration: origin at pixel (0, 0), x along the columns, y along
    the rows (made orthogonal to x), z = x cross y."""
    x = image_to_probe[:3, 0] / np.linalg.norm(image_to_probe[:3, 0])
    row = image_to_probe[:3, 1] - (image_to_probe[:3, 1] @ x) * x
    y = row / np.linalg.norm(row)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, y, np.cross(x, y)], axis=1)
    pose[:3, 3] = image_to_probe[:3, 3]
    return pose


class _Messages:
    """ROS 2 message builders on one typestore."""

    def __init__(self) -> None:
        from rosbags.typesys import Stores, get_typestore

        self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.types = self.store.types

    def header(self, stamp: int, frame_id: str) -> Any:
        time = self.types["builtin_interfaces/msg/Time"](sec=stamp // NS, nanosec=stamp % NS)
        return self.types["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)

    def image(self, stamp: int, frame: np.ndarray) -> Any:
        rows, cols = frame.shape
        return self.types["sensor_msgs/msg/Image"](
            header=self.header(stamp, IMAGE_FRAME), height=rows, width=cols,
            encoding="mono8", is_bigendian=0, step=cols,
            data=np.ascontiguousarray(frame, np.uint8).ravel(),
        )  # fmt: skip

    def transforms(self, stamp: int, parent: str, child: str, pose: np.ndarray) -> Any:
        from scipy.spatial.transform import Rotation

        x, y, z, w = Rotation.from_matrix(pose[:3, :3]).as_quat()
        types = self.types
        transform = types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](*pose[:3, 3]),
            rotation=types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
        )
        stamped = types["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp, parent), child_frame_id=child, transform=transform
        )
        return types[TF_TYPE](transforms=[stamped])

    def wrench(self, stamp: int, wrench: np.ndarray) -> Any:
        vector = self.types["geometry_msgs/msg/Vector3"]
        return self.types[WRENCH_TYPE](
            header=self.header(stamp, BASE_FRAME),
            wrench=self.types["geometry_msgs/msg/Wrench"](
                force=vector(*wrench[:3]), torque=vector(*wrench[3:])
            ),
        )


def _latched() -> Any:
    """QoS of /tf_static: reliable, transient local (late subscribers still get it)."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    zero = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
        zero, zero, QosLiveliness.AUTOMATIC, zero, False,
    )  # fmt: skip


def _write_bag(sweep: Sweep, folder: Path) -> list[str]:
    from rosbags.rosbag2 import StoragePlugin, Writer

    build = _Messages()
    store = build.store
    stamps = [round(float(t) * NS) for t in sweep.timestamps]
    if stamps[0] < 0:
        raise ResusError("timestamps before 0 s cannot be ROS stamps")
    with Writer(folder, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP) as bag:
        image = bag.add_connection(EXPORT_IMAGE_TOPIC, "sensor_msgs/msg/Image", typestore=store)
        tf = bag.add_connection("/tf", TF_TYPE, typestore=store)
        static = bag.add_connection(
            "/tf_static", TF_TYPE, typestore=store, offered_qos_profiles=[_latched()]
        )
        wrench = None
        if sweep.wrench is not None:
            wrench = bag.add_connection(EXPORT_WRENCH_TOPIC, WRENCH_TYPE, typestore=store)
        calibration = build.transforms(
            stamps[0], PROBE_FRAME, IMAGE_FRAME, image_frame_pose(sweep.image_to_probe)
        )
        bag.write(static, stamps[0], store.serialize_cdr(calibration, TF_TYPE))
        for index, stamp in enumerate(stamps):
            pose = build.transforms(stamp, BASE_FRAME, PROBE_FRAME, sweep.probe_to_base[index])
            bag.write(tf, stamp, store.serialize_cdr(pose, TF_TYPE))
            frame = build.image(stamp, sweep.frames[index])
            bag.write(image, stamp, store.serialize_cdr(frame, "sensor_msgs/msg/Image"))
            if wrench is not None and sweep.wrench is not None:
                message = build.wrench(stamp, sweep.wrench[index])
                bag.write(wrench, stamp, store.serialize_cdr(message, WRENCH_TYPE))
    topics = [EXPORT_IMAGE_TOPIC, "/tf", "/tf_static"]
    return [*topics, EXPORT_WRENCH_TOPIC] if wrench is not None else topics


def export_ros(sweep: Sweep, out: str | Path) -> list[str]:
    """Write `sweep` as a ROS 2 MCAP bag: one `.mcap` file, or a rosbag2 folder for any other
    path (which must not exist yet); return the topics written."""
    out = Path(out)
    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    try:
        if out.suffix != ".mcap":
            if out.exists():
                raise ResusError("exists already; a bag folder is never overwritten", out)
            return _write_bag(sweep, out)
        with tempfile.TemporaryDirectory(dir=out.parent, prefix=".export-ros-") as scratch:
            folder = Path(scratch) / out.stem
            topics = _write_bag(sweep, folder)
            os.replace(folder / f"{out.stem}.mcap", out)
            shutil.rmtree(folder)
        return topics
    except ResusError as error:
        if error.path is not None:
            raise
        raise ResusError(str(error), out) from None
    except OSError as error:
        raise ResusError(f"writing the bag failed ({error.strerror or error})", out) from None
