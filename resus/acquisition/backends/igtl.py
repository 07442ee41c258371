"""A real probe behind PLUS: B-mode frames from an OpenIGTLink server (PLUS, `resus sweep stream`).

PLUS (PlusServer) streams each tracked frame as an IMAGE message, by default `Image_Reference`
(its matrix maps pixel indices to PLUS's Reference frame in millimetres), and a TRANSFORM per
tool, e.g. `ProbeToReference`, all stamped with the frame's acquisition time. `IgtlProbe`
connects as a client and turns every IMAGE of its name into a `Frame`, stamped on `clock`
(the host's monotonic clock) the moment the message's header arrives, like `VideoProbe`: the
scanner pairs it with the robot's pose through `ScannerSettings.time_offset` (which starts from
`resus.acquisition.robot.host_clock_offset`), so the robot, not the tracker, places the frames
in the Sweep.

The tracker still has its say: the TRANSFORM with the same timestamp as an IMAGE is kept with
that frame (`TrackedFrame.tracker_pose`, metres) and in `tracker_track()`, a second pose
source to compare with the robot's (hand-eye calibration, tracking error). Frames are paired
with their TRANSFORM whichever of the two the server sends first.

Calibration (`image_to_probe`, metres): from a `resus.probe/1` file when the config names one;
otherwise from the stream itself, `inv(ProbeToReference) @ ImageToReference` of the first
frame, or, with `transform_name=None`, the IMAGE matrix itself (PLUS's `Image_Probe`, an image
sent in the probe frame). Messages are read on a plain socket and decoded by pyigtl: pyigtl's
own client keeps only the newest message of each name, so frames between two reads would be
lost, and it never notices that the server has gone.

A server that closes the link, or sends nothing for `timeout` seconds, ends the stream: `poll`
returns the frames received before it, then raises `ProbeLinkLost`, a `SafetyViolation`
(scanning on without images is blind), so the scanner stops the robot and keeps every frame.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from resus.acquisition.backends.video import BufferedProbe
from resus.acquisition.calibration.probe import ProbeCalibration
from resus.acquisition.probe import Frame
from resus.acquisition.safety import SafetyViolation
from resus.errors import ResusError
from resus.sweep.igtl import (
    DEFAULT_PORT,
    IMAGE_NAME,
    TRANSFORM_NAME,
    check_port,
    pose_from_mm,
)
from resus.sweep.images import to_grey
from resus.sweep.model import check_calibration
from resus.sweep.plus import from_mm
from sim.transforms import invert_pose

HEADER_SIZE = 58
"""Bytes of an OpenIGTLink message header (versions 1 and 2)."""
READ_INTERVAL = 0.05
"""How often the reader thread wakes to check for a stop request and silence (s)."""
LARGEST_BODY = 1 << 30
"""A larger message body is taken as a corrupt stream, not a frame."""


class ProbeLinkLost(SafetyViolation):
    """The OpenIGTLink stream ended (server gone, silent or sending unusable images)."""


@dataclass(frozen=True)
class TrackedFrame(Frame):
    """A frame with what came with it over OpenIGTLink."""

    tracker_pose: np.ndarray | None = None
    """ProbeToReference (metres) sent with the same timestamp, or None."""
    sent_at: float = 0.0
    """The message's own timestamp (the server's clock, s since 1970)."""


@dataclass(frozen=True)
class IgtlProbeConfig:
    """Which OpenIGTLink server to take frames from and what its messages are called."""

    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    image_name: str = IMAGE_NAME
    """IMAGE messages of this device name are the frames."""
    transform_name: str | None = TRANSFORM_NAME
    """TRANSFORM kept with each frame (and giving the calibration); None: no tracker."""
    timeout: float = 5.0
    """Longest wait to connect and for the first frame, and longest silence mid-stream (s)."""
    calibration: str | Path | None = None
    """`resus.probe/1` file giving image_to_probe; None: taken from the stream."""
    buffer_frames: int = 256
    """Frames kept between two polls; when it overflows the oldest are dropped (counted)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "port", check_port(self.port, "IgtlProbeConfig.port"))
        if not (np.isfinite(self.timeout) and self.timeout > 0):
            raise ResusError(f"IgtlProbeConfig.timeout must be positive, got {self.timeout}")
        if self.buffer_frames < 1:
            raise ResusError(
                f"IgtlProbeConfig.buffer_frames must be at least 1, got {self.buffer_frames}"
            )


def grey_frame(image: np.ndarray) -> np.ndarray:
    """The (rows, cols) 8-bit grey image of a pyigtl IMAGE array (k, j, i[, components])."""
    if image.dtype != np.uint8:
        raise ResusError(f"IMAGE pixels are {image.dtype}; expected 8-bit images")
    if image.shape[0] != 1:
        raise ResusError(f"IMAGE is a volume of {image.shape[0]} slices; expected one frame")
    image = image[0]
    channels = 1 if image.ndim == 2 else image.shape[2]
    if channels not in (1, 3, 4):
        raise ResusError(f"IMAGE has {channels} components per pixel; expected grey or RGB")
    return np.ascontiguousarray(to_grey(np.ascontiguousarray(image), "rgb"))  # IGTL is RGB(A)


class IgtlProbe(BufferedProbe):
    """Frames of an OpenIGTLink IMAGE stream, grey, stamped at receipt on `clock`."""

    def __init__(
        self, config: IgtlProbeConfig, clock: Callable[[], float] = time.monotonic
    ) -> None:
        """Connect and wait for the first frame (a missing server or stream fails here)."""
        super().__init__(clock, config.buffer_frames)
        self.config = config
        self.where = f"OpenIGTLink server {config.host}:{config.port}"
        calibration = None
        if config.calibration is not None:
            calibration = ProbeCalibration.from_yaml(config.calibration)
            if calibration.crop is not None:
                raise ResusError(
                    "crop does not apply to OpenIGTLink images (the server sends the "
                    "B-mode image itself)",
                    config.calibration,
                )
        self._socket = self._connect()
        self.ended: str | None = None
        """Why the stream stopped, or None while it runs."""
        self.seen: dict[str, set[str]] = {}
        """Device names received, by message type (to say what a server sends)."""
        self._track: list[tuple[float, np.ndarray]] = []
        self._pending: TrackedFrame | None = None
        self._latest_transform: tuple[float, np.ndarray] | None = None
        self._first: TrackedFrame | None = None
        self._first_matrix: np.ndarray | None = None
        self._changed = threading.Condition(self._lock)
        self._thread = threading.Thread(target=self._read_loop, name="igtl-read", daemon=True)
        self._thread.start()
        try:
            first, matrix = self._wait_for_first_frame()
            self._shape = (first.image.shape[0], first.image.shape[1])
            if calibration is not None:
                self._image_to_probe = calibration.image_to_probe(self._shape)
            else:
                self._image_to_probe = self._stream_calibration(first, matrix)
        except ResusError:
            self.close()
            raise

    def _connect(self) -> socket.socket:
        host, port, timeout = self.config.host, self.config.port, self.config.timeout
        try:
            connection = socket.create_connection((host, port), timeout=timeout)
        except socket.gaierror:
            raise ResusError(f"{self.where}: unknown host {host!r}") from None
        except ConnectionRefusedError:
            raise ResusError(f"{self.where}: connection refused (is the server running?)") from None
        except TimeoutError:
            raise ResusError(f"{self.where}: no answer within {timeout:g} s") from None
        except OSError as error:
            raise ResusError(f"{self.where}: {error.strerror or error}") from None
        connection.settimeout(READ_INTERVAL)
        return connection

    def _wait_for_first_frame(self) -> tuple[TrackedFrame, np.ndarray]:
        with self._changed:
            self._changed.wait_for(
                lambda: self._first is not None or self.ended is not None, self.config.timeout
            )
            if self._first is not None and self._first_matrix is not None:
                return self._first, self._first_matrix
            seen = "; ".join(
                f"{kind} {', '.join(sorted(names))}" for kind, names in self.seen.items()
            )
            reason = (
                self.ended
                or f"no IMAGE {self.config.image_name!r} within {self.config.timeout:g} s"
            )
        raise ResusError(f"{self.where}: {reason} (received: {seen or 'nothing'})")

    def _stream_calibration(self, first: TrackedFrame, image_matrix_mm: np.ndarray) -> np.ndarray:
        """image_to_probe from the first frame's IMAGE matrix (and its TRANSFORM)."""
        image_matrix = from_mm(image_matrix_mm)
        if self.config.transform_name is None:
            matrix = image_matrix  # the IMAGE is sent in the probe frame
        elif first.tracker_pose is None:
            raise ResusError(
                f"{self.where}: IMAGE {self.config.image_name!r} came without TRANSFORM "
                f"{self.config.transform_name!r}, so the calibration is unknown: give a "
                "calibration file, or transform_name=None for an image sent in the probe frame"
            )
        else:
            matrix = invert_pose(first.tracker_pose) @ image_matrix
        try:
            return check_calibration(matrix)
        except ResusError as error:
            raise ResusError(f"{self.where}: calibration from the stream: {error}") from None

    # -- the reader thread ----------------------------------------------------------------

    def _read_exactly(self, size: int, last_data: list[float]) -> bytes | None:
        """`size` bytes, or None when stopped; raises EOFError / TimeoutError on a dead link."""
        chunks, missing = [], size
        while missing:
            if self._stopping.is_set():
                return None
            try:
                chunk = self._socket.recv(min(missing, 1 << 20))
            except TimeoutError:
                if time.monotonic() - last_data[0] > self.config.timeout:
                    raise TimeoutError(f"sent nothing for {self.config.timeout:g} s") from None
                continue
            if not chunk:
                raise EOFError("the server closed the connection")
            last_data[0] = time.monotonic()
            chunks.append(chunk)
            missing -= len(chunk)
        return b"".join(chunks)

    def _read_loop(self) -> None:
        """Read messages until stopped or the link ends; queue the frames."""
        from pyigtl.messages import MessageBase

        last_data = [time.monotonic()]
        try:
            while True:
                header = self._read_exactly(HEADER_SIZE, last_data)
                received = self.clock()
                if header is None:
                    return
                fields = MessageBase.parse_header(header)
                if not 0 <= fields["body_size"] <= LARGEST_BODY:
                    raise ValueError(f"a message claims a body of {fields['body_size']} bytes")
                body = self._read_exactly(fields["body_size"], last_data)
                if body is None:
                    return
                self._handle(fields, body, received)
        except (OSError, EOFError, ValueError, ResusError) as error:
            reason = str(error) or type(error).__name__
        except Exception as error:  # a message pyigtl cannot decode
            reason = f"undecodable message ({type(error).__name__}: {error})"
        with self._changed:
            if self._pending is not None:
                self._emit(self._pending)
                self._pending = None
            if not self._stopping.is_set():
                self.ended = reason
            self._changed.notify_all()

    def _handle(self, fields: dict[str, Any], body: bytes, received: float) -> None:
        """Decode one message; pair IMAGEs with the TRANSFORM of the same timestamp."""
        from pyigtl.messages import MessageBase

        kind, name = fields["message_type"], fields["device_name"]
        with self._lock:
            self.seen.setdefault(kind, set()).add(name)
        config = self.config
        wanted_image = kind == "IMAGE" and name == config.image_name
        wanted_transform = kind == "TRANSFORM" and name == config.transform_name
        if not (wanted_image or wanted_transform):
            return
        message = MessageBase.create_message(kind)
        message.unpack(fields, body)
        stamp = float(fields["timestamp"])
        with self._changed:
            if wanted_transform:
                pose = pose_from_mm(message.matrix)
                self._latest_transform = (stamp, pose)
                pending = self._pending
                if pending is not None and pending.sent_at == stamp:
                    self._emit(TrackedFrame(pending.timestamp, pending.image, None, pose, stamp))
                    self._pending = None
                return
            frame = TrackedFrame(received, self._checked_image(message.image), None, None, stamp)
            if self._first_matrix is None:
                self._first_matrix = np.array(message.ijk_to_world_matrix, dtype=np.float64)
            if self._pending is not None:
                self._emit(self._pending)  # its TRANSFORM never came
                self._pending = None
            latest = self._latest_transform
            if config.transform_name is None:
                self._emit(frame)
            elif latest is not None and latest[0] == stamp:
                self._emit(TrackedFrame(received, frame.image, None, latest[1], stamp))
            else:
                self._pending = frame

    def _checked_image(self, image: np.ndarray) -> np.ndarray:
        grey = grey_frame(np.asarray(image))
        first = self._first
        if first is not None and grey.shape != first.image.shape:
            rows, cols = first.image.shape
            raise ResusError(
                f"IMAGE size changed from {cols} x {rows} to {grey.shape[1]} x {grey.shape[0]} px"
            )
        return grey

    def _emit(self, frame: TrackedFrame) -> None:
        """Queue a finished frame (the lock is held)."""
        self._queue(frame)
        if frame.tracker_pose is not None:
            self._track.append((frame.timestamp, frame.tracker_pose))
        if self._first is None:
            self._first = frame
        self._changed.notify_all()

    # -- the Probe interface --------------------------------------------------------------

    def poll(self) -> list[Frame]:
        """Frames received since the last call, oldest first; once the stream has ended and
        every frame received before has been returned, raises `ProbeLinkLost`."""
        with self._lock:
            frames = self._take_frames()
            ended = self.ended
        if not frames and ended is not None:
            raise ProbeLinkLost(f"{self.where}: {ended}")
        return frames

    def tracker_track(self) -> tuple[np.ndarray, np.ndarray]:
        """(times on `clock`, ProbeToReference poses (N, 4, 4) in metres) of every frame
        received with its TRANSFORM: the tracker's view, to compare with the robot's."""
        with self._lock:
            track = list(self._track)
        if not track:
            return np.zeros(0), np.zeros((0, 4, 4))
        return np.array([t for t, _ in track]), np.stack([pose for _, pose in track])

    def close(self) -> None:
        """Stop the reader thread and disconnect; safe to call twice."""
        self._stop_thread()
        with contextlib.suppress(OSError):
            self._socket.shutdown(socket.SHUT_RDWR)
        self._socket.close()
