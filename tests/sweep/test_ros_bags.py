"""ROS bags in and out of Sweeps (`resus.sweep.ros`), on bags written here by rosbags' own
writers: ROS 1 `.bag`, ROS 2 sqlite3 and ROS 2 MCAP. Imported field by field; a Sweep survives
Sweep -> bag -> Sweep; poses interpolated at image stamps follow an analytic probe path; every
bad input is one line naming the bag."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from scipy.spatial.transform import Rotation
from sweep_samples import sample_sweep

from resus.errors import ResusError
from resus.sweep.plus import write_plus_calibration
from resus.sweep.ros import export_ros, image_frame_pose, image_message_to_grey, import_ros
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

NS = 1_000_000_000
ROWS, COLS = 32, 48
PROBE = LinearProbe(cols=COLS, rows=ROWS)
T0 = 1_700_000_000 * NS
"""An epoch-sized first stamp, as real bags have."""


class Bag:
    """Messages for one bag, built on a ROS 1 or ROS 2 typestore and written by rosbags."""

    def __init__(self, ros: int) -> None:
        self.ros = ros
        if ros == 1:
            self.store = get_typestore(Stores.ROS1_NOETIC)
            self.store.register(
                get_types_from_msg(
                    "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
                )
            )
        else:
            self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.t = self.store.types
        self.messages: list[tuple[str, str, int, object]] = []

    def header(self, stamp: int, frame: str = "") -> object:
        time = self.t["builtin_interfaces/msg/Time"](sec=stamp // NS, nanosec=stamp % NS)
        extra = {"seq": 0} if self.ros == 1 else {}
        return self.t["std_msgs/msg/Header"](stamp=time, frame_id=frame, **extra)

    def add(self, topic: str, msgtype: str, stamp: int, message: object) -> None:
        self.messages.append((topic, msgtype, stamp, message))

    def image(self, topic, stamp, pixels, encoding="mono8", bigendian=0, pad=0) -> None:
        data = np.ascontiguousarray(pixels)
        if encoding == "mono16":
            data = data.astype(">u2" if bigendian else "<u2")
        rows = data.reshape(data.shape[0], -1).view(np.uint8)
        rows = np.pad(rows, ((0, 0), (0, pad)))
        message = self.t["sensor_msgs/msg/Image"](
            header=self.header(stamp, "us"), height=pixels.shape[0], width=pixels.shape[1],
            encoding=encoding, is_bigendian=bigendian, step=rows.shape[1], data=rows.ravel(),
        )  # fmt: skip
        self.add(topic, "sensor_msgs/msg/Image", stamp, message)

    def compressed(self, topic, stamp, pixels, fmt="png") -> None:
        ok, encoded = cv2.imencode(f".{fmt}", pixels)
        assert ok
        message = self.t["sensor_msgs/msg/CompressedImage"](
            header=self.header(stamp, "us"), format=fmt, data=encoded.ravel()
        )
        self.add(topic, "sensor_msgs/msg/CompressedImage", stamp, message)

    def _transform(self, pose):
        x, y, z, w = Rotation.from_matrix(pose[:3, :3]).as_quat()
        return (
            self.t["geometry_msgs/msg/Vector3"](*pose[:3, 3]),
            self.t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
        )

    def pose(self, topic, stamp, pose) -> None:
        _, rotation = self._transform(pose)
        point = self.t["geometry_msgs/msg/Point"](*pose[:3, 3])
        message = self.t["geometry_msgs/msg/PoseStamped"](
            header=self.header(stamp, "base"),
            pose=self.t["geometry_msgs/msg/Pose"](position=point, orientation=rotation),
        )
        self.add(topic, "geometry_msgs/msg/PoseStamped", stamp, message)

    def tf(self, stamp, parent, child, pose, static=False) -> None:
        translation, rotation = self._transform(pose)
        transform = self.t["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp, parent), child_frame_id=child,
            transform=self.t["geometry_msgs/msg/Transform"](
                translation=translation, rotation=rotation
            ),
        )  # fmt: skip
        message = self.t["tf2_msgs/msg/TFMessage"](transforms=[transform])
        self.add("/tf_static" if static else "/tf", "tf2_msgs/msg/TFMessage", stamp, message)

    def wrench(self, topic, stamp, values) -> None:
        vector = self.t["geometry_msgs/msg/Vector3"]
        message = self.t["geometry_msgs/msg/WrenchStamped"](
            header=self.header(stamp, "base"),
            wrench=self.t["geometry_msgs/msg/Wrench"](
                force=vector(*values[:3]), torque=vector(*values[3:])
            ),
        )
        self.add(topic, "geometry_msgs/msg/WrenchStamped", stamp, message)

    def write(self, path: Path, storage: str = "sqlite3") -> Path:
        """ROS 1 `.bag` (ros=1), else a ROS 2 folder with `storage` 'sqlite3' or 'mcap'."""
        ordered = sorted(self.messages, key=lambda m: m[2])
        if self.ros == 1:
            writer = Writer1(path)
            serialize = self.store.serialize_ros1
        else:
            plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
            writer = Writer2(path, version=9, storage_plugin=plugin)
            serialize = self.store.serialize_cdr
        with writer:
            connections = {}
            for topic, msgtype, stamp, message in ordered:
                if topic not in connections:
                    connections[topic] = writer.add_connection(topic, msgtype, typestore=self.store)
                writer.write(connections[topic], stamp, serialize(message, msgtype))
        return path


def calibration_yaml(tmp_path: Path) -> Path:
    path = tmp_path / "probe.yaml"
    spacing = [PROBE.pixel_width * 1e3, PROBE.pixel_height * 1e3]
    path.write_text(yaml.safe_dump({"schema": "resus.probe/1", "pixel_spacing_mm": spacing}))
    return path


def frames(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (n, ROWS, COLS), dtype=np.uint8)


def poses(n: int, seed: int = 0) -> np.ndarray:
    rotations = Rotation.random(n, random_state=seed).as_matrix()
    return np.stack([make_pose(r, (0.1, 0.2 + 1e-3 * i, 0.05)) for i, r in enumerate(rotations)])


# -- import, field by field ----------------------------------------------------------------


def test_ros1_bag_images_and_posestamped(tmp_path):
    images, truth = frames(5, seed=1), poses(5, seed=1)
    bag = Bag(ros=1)
    stamps = [T0 + k * NS // 20 for k in range(5)]
    for k in range(5):
        bag.pose("/probe_pose", stamps[k], truth[k])
        bag.image("/us", stamps[k], images[k], pad=3 if k == 2 else 0)
    bag.image("/us", stamps[0] - NS, images[0])  # before the first pose: left out
    bag.image("/us", stamps[2], images[4])  # repeats a stamp: left out
    bag.image("/us", stamps[4] + 1, images[0])  # 1 ns after the last pose: left out
    path = bag.write(tmp_path / "scan.bag")

    result = import_ros(
        path, "/us", pose_topic="/probe_pose", calibration=calibration_yaml(tmp_path)
    )
    sweep = result.sweep
    np.testing.assert_array_equal(sweep.frames, images)
    np.testing.assert_allclose(sweep.probe_to_base, truth, atol=1e-12)
    np.testing.assert_array_equal(sweep.timestamps, np.array(stamps) * 1e-9)
    np.testing.assert_allclose(sweep.image_to_probe, PROBE.image_to_probe())
    assert sweep.source == "real" and sweep.subject == "scan" and sweep.labels is None
    assert sweep.wrench is None
    assert (result.images, result.outside_poses, result.repeated_stamps, result.poses) == (
        8,
        2,
        1,
        5,
    )
    assert result.pose_span == (stamps[0] * 1e-9, stamps[4] * 1e-9)


def test_ros2_sqlite3_bag_with_a_tf_chain_and_compressed_images(tmp_path):
    images, tool = frames(4, seed=2), poses(4, seed=2)
    tool_to_probe = make_pose(Rotation.from_euler("z", 90, degrees=True).as_matrix(), (0, 0, 0.12))
    bag = Bag(ros=2)
    bag.tf(T0, "tool0", "probe", tool_to_probe, static=True)
    bag.tf(T0, "world", "base_link", make_pose(np.eye(3), (1.0, 2.0, 0.0)), static=True)
    stamps = [T0 + k * NS // 10 for k in range(4)]
    for k in range(4):
        bag.tf(stamps[k], "base_link", "tool0", tool[k])
        bag.compressed("/us/compressed", stamps[k], images[k], "png")
    path = bag.write(tmp_path / "scan_sqlite")
    result = import_ros(
        path, "/us/compressed", tf=("base_link", "probe"), calibration=PROBE.image_to_probe(),
        subject="pig-3",
    )  # fmt: skip
    np.testing.assert_array_equal(result.sweep.frames, images)  # PNG is lossless
    np.testing.assert_allclose(result.sweep.probe_to_base, tool @ tool_to_probe, atol=1e-12)
    assert result.sweep.subject == "pig-3" and result.poses == 4 and result.outside_poses == 0
    # the chain may also run up and down the tree: world -> base_link -> tool0 -> probe
    world = import_ros(path, "/us/compressed", tf=("world", "probe"), calibration=np.eye(4))
    offset = make_pose(np.eye(3), (1.0, 2.0, 0.0))
    np.testing.assert_allclose(world.sweep.probe_to_base, offset @ tool @ tool_to_probe, atol=1e-12)


@pytest.mark.parametrize("lone_file", [False, True], ids=["folder", "lone-mcap"])
def test_ros2_mcap_bag_with_colour_images_and_a_wrench(tmp_path, lone_file):
    images, truth = frames(3, seed=3), poses(3, seed=3)
    bag = Bag(ros=2)
    wrenches = np.arange(18, dtype=float).reshape(3, 6)
    for k in range(3):
        stamp = T0 + k * NS // 10
        bag.pose("/pose", stamp, truth[k])
        bag.image("/us", stamp, np.repeat(images[k][..., None], 3, axis=2), "bgr8")
        bag.wrench("/wrench", stamp, wrenches[k])
    path = bag.write(tmp_path / "scan_mcap", storage="mcap")
    if lone_file:
        path = next(path.glob("*.mcap"))
    result = import_ros(
        path, "/us", pose_topic="/pose", calibration=PROBE.image_to_probe(), wrench_topic="/wrench"
    )
    np.testing.assert_array_equal(result.sweep.frames, images)  # grey in, grey out
    np.testing.assert_allclose(result.sweep.probe_to_base, truth, atol=1e-12)
    np.testing.assert_allclose(result.sweep.wrench, wrenches)


# -- encodings -----------------------------------------------------------------------------


def decoded(bag: Bag) -> np.ndarray:
    _, msgtype, _, message = bag.messages[-1]
    return image_message_to_grey(message, msgtype)


def test_encodings_to_grey():
    rng = np.random.default_rng(4)
    grey = rng.integers(0, 256, (ROWS, COLS), dtype=np.uint8)
    colour = rng.integers(0, 256, (ROWS, COLS, 3), dtype=np.uint8)
    bag = Bag(ros=2)
    bag.image("/us", T0, grey, "mono8", pad=5)
    np.testing.assert_array_equal(decoded(bag), grey)
    deep = grey.astype(np.uint16) * 257  # 8-bit values spread over 16 bits
    for bigendian in (0, 1):
        bag.image("/us", T0, deep, "mono16", bigendian=bigendian)
        np.testing.assert_array_equal(decoded(bag), grey)
    bag.image("/us", T0, np.array([[0, 128, 129, 385, 65535]], np.uint16), "mono16")
    np.testing.assert_array_equal(decoded(bag), [[0, 0, 1, 1, 255]])  # round(v / 257)
    for encoding, code in (("rgb8", cv2.COLOR_RGB2GRAY), ("bgr8", cv2.COLOR_BGR2GRAY)):
        bag.image("/us", T0, colour, encoding)
        np.testing.assert_array_equal(decoded(bag), cv2.cvtColor(colour, code))
    bag.compressed("/us", T0, grey, "jpg")
    assert np.abs(decoded(bag).astype(int) - grey).mean() < 20  # lossy, but the same image
    bag.compressed("/us", T0, deep, "png")
    np.testing.assert_array_equal(decoded(bag), grey)  # a 16-bit PNG like mono16


# -- round trip and an analytic path ---------------------------------------------------------


@pytest.mark.parametrize("out_name", ["scan.mcap", "scan_bag"])
def test_sweep_to_bag_to_sweep(tmp_path, out_name):
    sweep = sample_sweep(n=6, rows=ROWS, cols=COLS, seed=5)
    topics = export_ros(sweep, tmp_path / out_name)
    assert topics == ["/us/image", "/tf", "/tf_static", "/us/wrench"]
    write_plus_calibration(sweep.image_to_probe, tmp_path / "config.xml")
    back = import_ros(
        tmp_path / out_name, "/us/image", tf=("base", "probe"),
        calibration=tmp_path / "config.xml", wrench_topic="/us/wrench",
    ).sweep  # fmt: skip
    np.testing.assert_array_equal(back.frames, sweep.frames)
    np.testing.assert_allclose(back.probe_to_base, sweep.probe_to_base, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.timestamps, sweep.timestamps, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.wrench, sweep.wrench, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.image_to_probe, sweep.image_to_probe, rtol=0, atol=1e-15)


def test_the_exported_bag_is_what_ros_tools_expect(tmp_path):
    sweep = sample_sweep(n=2, rows=ROWS, cols=COLS, seed=6, optional=False)
    assert export_ros(sweep, tmp_path / "bag") == ["/us/image", "/tf", "/tf_static"]
    with AnyReader([tmp_path / "bag"]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types == {
            "/us/image": "sensor_msgs/msg/Image",
            "/tf": "tf2_msgs/msg/TFMessage",
            "/tf_static": "tf2_msgs/msg/TFMessage",
        }
        (static,) = [c for c in reader.connections if c.topic == "/tf_static"]
        assert static.ext.offered_qos_profiles[0].durability.name == "TRANSIENT_LOCAL"
        seen = {}
        for connection, _, raw in reader.messages():
            seen.setdefault(connection.topic, []).append(
                reader.deserialize(raw, connection.msgtype)
            )
    image = seen["/us/image"][0]
    assert (image.encoding, image.header.frame_id, image.width, image.height) == (
        "mono8", "probe_image", COLS, ROWS,
    )  # fmt: skip
    link = seen["/tf"][1].transforms[0]
    assert (link.header.frame_id, link.child_frame_id) == ("base", "probe")
    (calibration,) = seen["/tf_static"][0].transforms
    assert (calibration.header.frame_id, calibration.child_frame_id) == ("probe", "probe_image")
    rigid = image_frame_pose(sweep.image_to_probe)
    spacing = np.linalg.norm(sweep.image_to_probe[:3, :2], axis=0)
    np.testing.assert_allclose(rigid[:3, :2] * spacing, sweep.image_to_probe[:3, :2], atol=1e-15)
    assert (tmp_path / "bag" / "metadata.yaml").is_file()
    assert next((tmp_path / "bag").glob("*.mcap")).read_bytes()[:8] == b"\x89MCAP0\r\n"


def analytic_pose(t: np.ndarray) -> np.ndarray:
    """Straight along x at 20 mm/s for 0.5 s, then a quarter turn of radius 20 mm about z,
    the probe turning with the path (its x axis along the travel)."""
    speed, radius, straight = 0.02, 0.02, 0.5
    out = []
    for time in np.atleast_1d(t):
        if time <= straight:
            position, heading = np.array([speed * time, 0.0, 0.1]), 0.0
        else:
            heading = speed * (time - straight) / radius
            position = np.array(
                [speed * straight + radius * np.sin(heading), radius * (1 - np.cos(heading)), 0.1]
            )
        out.append(make_pose(Rotation.from_euler("z", heading).as_matrix(), position))
    return np.stack(out)


@pytest.mark.parametrize("source", ["pose", "tf"])
def test_poses_at_image_stamps_follow_the_analytic_path(tmp_path, source):
    bag = Bag(ros=2)
    pose_stamps = T0 + np.arange(0, 1001) * 2_000_000  # 500 Hz for 2 s
    for stamp, pose in zip(pose_stamps, analytic_pose((pose_stamps - T0) * 1e-9), strict=True):
        if source == "pose":
            bag.pose("/pose", int(stamp), pose)
        else:
            bag.tf(int(stamp), "base", "probe", pose)
    image_stamps = T0 + 777_777 + np.arange(60) * 33_333_333  # 30 Hz, between pose stamps
    images = frames(60, seed=7)
    for stamp, image in zip(image_stamps, images, strict=True):
        bag.image("/us", int(stamp), image)
    path = bag.write(tmp_path / "path_bag", storage="mcap")
    options = {"pose_topic": "/pose"} if source == "pose" else {"tf": ("base", "probe")}
    sweep = import_ros(path, "/us", calibration=PROBE.image_to_probe(), **options).sweep
    assert len(sweep) == 60
    truth = analytic_pose((image_stamps - T0) * 1e-9)
    position_error = np.linalg.norm(sweep.probe_to_base[:, :3, 3] - truth[:, :3, 3], axis=1)
    assert position_error.max() < 1e-6  # 1 um
    rotation_error = np.abs(sweep.probe_to_base[:, :3, :3] - truth[:, :3, :3]).max()
    assert rotation_error < 1e-9
    assert (truth[-1, :3, 3] - truth[0, :3, 3])[1] > 0.01  # the path did turn


# -- errors --------------------------------------------------------------------------------


@pytest.fixture
def simple_bag(tmp_path) -> Path:
    bag = Bag(ros=2)
    for k in range(3):
        bag.pose("/pose", T0 + k * NS, poses(3)[k])
        bag.image("/us", T0 + k * NS, frames(3)[k])
    bag.tf(T0, "base", "tool0", np.eye(4))
    bag.image("/odd", T0, frames(1)[0], "yuv422")
    return bag.write(tmp_path / "simple")


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"image_topic": "/camera"}, "no image topic '/camera' in the bag (topics: /odd "),
        (
            {"image_topic": "/pose"},
            "image topic '/pose' is geometry_msgs/msg/PoseStamped, expected",
        ),
        ({"pose_topic": "/missing"}, "no pose topic '/missing' in the bag"),
        ({"pose_topic": "/us"}, "pose topic '/us' is sensor_msgs/msg/Image, expected"),
        ({"pose_topic": None, "tf": ("base", "probe")}, "tf has no chain from 'base' to 'probe'"),
        ({"image_topic": "/odd"}, "image encoding 'yuv422' is not supported (mono8, mono16"),
        ({"pose_topic": None}, "give exactly one pose source"),
    ],
)
def test_a_bad_import_is_one_line_naming_the_bag(simple_bag, arguments, message):
    options = {"image_topic": "/us", "pose_topic": "/pose", "calibration": np.eye(4), **arguments}
    with pytest.raises(ResusError) as error:
        import_ros(simple_bag, **options)
    text = str(error.value)
    assert "\n" not in text and message in text, text
    if "pose source" not in message:
        assert text.startswith(f"{simple_bag}: ")


def test_images_outside_the_pose_stream_or_no_bag_are_one_line(tmp_path):
    bag = Bag(ros=2)
    bag.pose("/pose", T0, np.eye(4))
    bag.pose("/pose", T0 + NS, np.eye(4))
    bag.image("/us", T0 + 5 * NS, frames(1)[0])
    path = bag.write(tmp_path / "late")
    with pytest.raises(ResusError, match="none of the 1 images lies within the pose stream"):
        import_ros(path, "/us", pose_topic="/pose", calibration=np.eye(4))
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ResusError, match=r"notes\.txt: not a ROS bag"):
        import_ros(tmp_path / "notes.txt", "/us", pose_topic="/p", calibration=np.eye(4))
    (tmp_path / "broken.bag").write_bytes(b"#ROSBAG V2.0\nrubbish")
    with pytest.raises(ResusError, match=r"broken.bag: cannot read the bag \("):
        import_ros(tmp_path / "broken.bag", "/us", pose_topic="/p", calibration=np.eye(4))
    with pytest.raises(ResusError, match=r"missing\.bag: no such file"):
        import_ros(tmp_path / "missing.bag", "/us", pose_topic="/p", calibration=np.eye(4))
    sweep = sample_sweep(n=2)
    export_ros(sweep, tmp_path / "exists")
    with pytest.raises(ResusError, match="exists: exists already"):
        export_ros(sweep, tmp_path / "exists")


def test_a_calibration_with_a_crop_crops_every_image_and_places_the_cropped_pixels(tmp_path):
    """The frame grabber's crop of a probe calibration applies to bag images too: the sweep
    holds the cropped images, and its calibration maps their pixels (pixel (0, 0) is the
    crop's corner) as the calibration file says."""
    images, truth = frames(3, seed=4), poses(3, seed=4)
    bag = Bag(ros=2)
    for k in range(3):
        bag.pose("/pose", T0 + k * NS, truth[k])
        bag.image("/us", T0 + k * NS, images[k])
    path = bag.write(tmp_path / "cropped")
    calibration = tmp_path / "probe.yaml"
    calibration.write_text(
        yaml.safe_dump(
            {"schema": "resus.probe/1", "pixel_spacing_mm": [0.2, 0.3], "crop": [5, 2, 40, 28]}
        )
    )
    sweep = import_ros(path, "/us", pose_topic="/pose", calibration=calibration).sweep
    np.testing.assert_array_equal(sweep.frames, images[:, 2:30, 5:45])
    # ProbeCalibration's convention: the cropped image's top row lies on the array (pixel
    # centres half a row deep), its middle column at the array's centre; x along the array,
    # z along the beam (metres)
    middle = sweep.image_to_probe @ [19.5, 0.0, 0.0, 1.0]
    np.testing.assert_allclose(middle[:3], [0.0, 0.0, 0.15e-3], atol=1e-12)
    corner = sweep.image_to_probe @ [0.0, 0.0, 0.0, 1.0]
    far = sweep.image_to_probe @ [39.0, 27.0, 0.0, 1.0]
    np.testing.assert_allclose(far[:3] - corner[:3], [39 * 0.2e-3, 0.0, 27 * 0.3e-3], atol=1e-12)

    calibration.write_text(
        yaml.safe_dump(
            {"schema": "resus.probe/1", "pixel_spacing_mm": [0.2, 0.3], "crop": [20, 0, 40, 28]}
        )
    )
    with pytest.raises(ResusError) as error:
        import_ros(path, "/us", pose_topic="/pose", calibration=calibration)
    assert str(error.value) == (
        f"{calibration}: crop (20, 0, 40, 28) (x, y, width, height) reaches outside the bag's "
        f"{COLS} x {ROWS} images"
    )
