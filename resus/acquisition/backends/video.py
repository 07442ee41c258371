"""A real probe: the ultrasound scanner's video output through a frame grabber (OpenCV).

`VideoProbe` opens `cv2.VideoCapture` on a device index (a USB/HDMI grabber is `0`), a stream
URL, or a video file (replayed at its own frame rate, as a grabber would deliver it). A
background thread grabs frames as they come and stamps each one with `time.monotonic()` the
moment `grab()` returns, before decoding, which is the closest the host sees to the capture
instant. Frames are turned to grey and cut to the calibration's crop rectangle, the part of
the scanner's screen that holds the B-mode image.

Clock: timestamps are on the host's monotonic clock, not the robot's. The scanner maps them
with `ScannerSettings.time_offset` = (robot clock - monotonic clock, measured once at the
start: `resus.acquisition.robot.host_clock_offset`) + the video latency correction found by
temporal calibration (`resus calibrate-time`); `resus scan` does both.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import numpy as np

from resus.acquisition.calibration.probe import ProbeCalibration, parse_crop
from resus.acquisition.probe import Frame, Probe
from resus.errors import ResusError
from resus.sweep.images import to_grey


@dataclass(frozen=True)
class VideoProbeConfig:
    """Which video to grab and how to read its images."""

    source: int | str
    """Device index (int), stream URL or video file path."""
    calibration: str | Path
    """Probe calibration file (`resus.probe/1`): crop rectangle and image_to_probe."""
    crop: tuple[int, int, int, int] | None = None
    """(x, y, width, height) overriding the calibration file's crop."""
    pace: bool = True
    """Replay a file source at its recorded frame rate (False: as fast as it decodes)."""
    buffer_frames: int = 256
    """Frames kept between two polls; when it overflows the oldest are dropped (counted)."""

    def __post_init__(self) -> None:
        if self.crop is not None:
            object.__setattr__(self, "crop", parse_crop(self.crop, "VideoProbeConfig.crop"))
        if self.buffer_frames < 1:
            raise ResusError(
                f"VideoProbeConfig.buffer_frames must be at least 1, got {self.buffer_frames}"
            )


class BufferedProbe(Probe):
    """A probe whose background thread `_thread` queues frames until `poll` takes them: at most
    `buffer_frames`, the oldest dropped (and counted) beyond. Subclasses set `_thread`,
    `_image_to_probe` and `_shape`."""

    _thread: threading.Thread
    _image_to_probe: np.ndarray
    _shape: tuple[int, int]

    def __init__(self, clock: Callable[[], float], buffer_frames: int) -> None:
        self.clock = clock
        self.dropped = 0
        """Frames lost because nobody polled for `buffer_frames` frames."""
        self._buffer_frames = buffer_frames
        self._frames: deque[Frame] = deque()
        self._lock = threading.Lock()
        self._stopping = threading.Event()

    def _queue(self, frame: Frame) -> None:
        """Append a frame, dropping the oldest when the buffer is full (hold `_lock`)."""
        if len(self._frames) >= self._buffer_frames:
            self._frames.popleft()
            self.dropped += 1
        self._frames.append(frame)

    def _take_frames(self) -> list[Frame]:
        """Every queued frame, oldest first, leaving the buffer empty (hold `_lock`)."""
        frames = list(self._frames)
        self._frames.clear()
        return frames

    def _stop_thread(self) -> None:
        """Ask the background thread to stop and wait for it (a while at most)."""
        self._stopping.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    @property
    def image_to_probe(self) -> np.ndarray:
        return self._image_to_probe

    @property
    def shape(self) -> tuple[int, int]:
        return self._shape

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class VideoProbe(BufferedProbe):
    """Frames of a video source, cropped and grey, stamped at capture on `clock`."""

    def __init__(
        self, config: VideoProbeConfig, clock: Callable[[], float] = time.monotonic
    ) -> None:
        """Open the source and read its first frame (a bad source or crop fails here)."""
        import cv2

        super().__init__(clock, config.buffer_frames)
        self.config = config
        calibration = ProbeCalibration.from_yaml(config.calibration)
        # OpenCV's own warnings would repeat the one-line errors below
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
        self._capture = cv2.VideoCapture(config.source)
        if not self._capture.isOpened():
            raise ResusError(f"video source {config.source!r} cannot be opened")
        ok = self._capture.grab()
        stamp = clock()
        ok, first = self._capture.retrieve() if ok else (False, None)
        if not ok or first is None:
            self._capture.release()
            raise ResusError(f"video source {config.source!r} opened but delivers no frames")
        try:
            grey = to_grey(first)
            self.crop = self._checked_crop(config.crop or calibration.crop, grey.shape)
        except ResusError:
            self._capture.release()
            raise
        self._shape = (self.crop[3], self.crop[2])
        self._image_to_probe = calibration.image_to_probe(self._shape)
        self.frame_rate = float(self._capture.get(cv2.CAP_PROP_FPS) or 0.0)
        """Frames per second the source reports (0 when it does not say)."""
        self.ended: str | None = None
        """Why the source stopped delivering (end of file, lost device), or None."""
        self._frames.append(Frame(stamp, self._cut(grey)))
        self._is_file = isinstance(config.source, str) and Path(config.source).is_file()
        self._thread = threading.Thread(target=self._grab_loop, name="video-grab", daemon=True)
        self._thread.start()

    @staticmethod
    def _checked_crop(
        crop: tuple[int, int, int, int] | None, shape: tuple[int, int]
    ) -> tuple[int, int, int, int]:
        rows, cols = shape
        if crop is None:
            return 0, 0, cols, rows
        x, y, width, height = crop
        if x + width > cols or y + height > rows:
            raise ResusError(
                f"crop {crop} (x, y, width, height) reaches outside the video's "
                f"{cols} x {rows} frames"
            )
        return crop

    def _cut(self, grey: np.ndarray) -> np.ndarray:
        x, y, width, height = self.crop
        return np.ascontiguousarray(grey[y : y + height, x : x + width])

    def _grab_loop(self) -> None:
        """Grab, stamp, convert and queue frames until closed or the source ends."""
        start = self.clock()
        period = 1.0 / self.frame_rate if self.frame_rate > 0 else 0.0
        index = 1
        while not self._stopping.is_set():
            if self._is_file and self.config.pace and period > 0:
                delay = start + index * period - self.clock()
                if delay > 0 and self._stopping.wait(delay):
                    break
            if not self._capture.grab():
                self.ended = "end of the video" if self._is_file else "the video source stopped"
                break
            stamp = self.clock()
            ok, image = self._capture.retrieve()
            if not ok or image is None:
                self.ended = "the video source delivered an unreadable frame"
                break
            frame = Frame(stamp, self._cut(to_grey(image)))
            with self._lock:
                self._queue(frame)
            index += 1

    def poll(self) -> list[Frame]:
        """Frames grabbed since the last call, oldest first."""
        with self._lock:
            return self._take_frames()

    def close(self) -> None:
        """Stop the grab thread and release the device; safe to call twice."""
        self._stop_thread()
        self._capture.release()
