"""OpenIGTLink out: stream a scan's frames to 3D Slicer (or any client) the way PLUS does.

Each frame goes out as two messages with the same timestamp, packed by pyigtl:

- TRANSFORM `ProbeToReference`: `probe_to_base` with its translation in millimetres;
- IMAGE `Image_Reference`: the B-mode frame (8-bit grey, one slice) whose matrix maps pixel
  indices to the Reference frame in millimetres, `ImageToReference = ProbeToReference @
  ImageToProbe`, the calibration's pixel size included.

The Reference frame is the robot base. Millimetres exist only on the wire, as in PLUS; the
Sweep and everything else stay in metres.

The IMAGE matrix, precisely. pyigtl's `ImageMessage(image, ijk_to_world_matrix)` takes the
voxel array with axes (k, j, i), so a frame of shape (rows, cols) is sent as (1, rows, cols):
i is the column, j the row, k the single slice. `ijk_to_world_matrix` maps a voxel index
`(i, j, k, 1)` (the centre of that voxel) to the world; on the wire OpenIGTLink stores its
three columns with the spacing multiplied in (T, S, N) and, instead of the origin, the world
position of the image centre `(size - 1) / 2`, which pyigtl computes. 3D Slicer (OpenIGTLinkIF,
`igtlioImageConverter`) reads the matrix back as IJK-to-RAS: directions and spacing from T, S
and N, origin = centre minus the same half extents, so pixel `(col, row)` of frame i lands in
Slicer at `ImageToReference[i] @ (col, row, 0, 1)`, exactly where the Sweep puts it
(`pixels_to_world`, times 1000). Slicer does not consult the message's coordinate-system field;
it is set to RAS, the OpenIGTLink library's (and so PLUS's) default, and Slicer shows the base
frame's x, y, z as its R, A, S. The N column (slice direction) is the calibration's third
column, which a valid calibration never leaves zero, so Slicer can normalise it.

`IgtlServer` is a `FrameSink`: give it to the Scanner as a listener and a scan streams live.
`stream_sweep` replays a Sweep file at its recorded timing. The server is written on a plain
socket (pyigtl packs the messages): pyigtl's own server binds only 127.0.0.1 or an interface,
serves one client, replaces the process's SIGINT/SIGTERM handlers and blocks a waiting send
while no client is connected. This one binds the host it is given (127.0.0.1 by default),
serves any number of clients, each through its own bounded queue so that a slow or vanished
client never stalls the scan, and drops the oldest frames of a client that falls behind.
"""

from __future__ import annotations

import contextlib
import errno
import select
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import Sweep, SweepFrame, check_calibration
from resus.sweep.plus import MM_PER_M, to_mm

DEFAULT_PORT = 18944
"""OpenIGTLink's registered port, and PLUS's default."""
LOOPBACK = "127.0.0.1"
IMAGE_NAME = "Image_Reference"
TRANSFORM_NAME = "ProbeToReference"
QUEUE_FRAMES = 64
"""Frames a client may fall behind before its oldest unsent frames are dropped."""
SEND_TIMEOUT = 2.0
"""A client that accepts no data for this long is dropped (s)."""
POLL_INTERVAL = 0.05
"""How often the server's threads look for new clients, data and the stop request (s)."""


def check_port(port: object, what: str = "OpenIGTLink port", *, allow_zero: bool = False) -> int:
    """A TCP port number, 1..65535 (0 too when `allow_zero`: any free port, to listen on)."""
    low = 0 if allow_zero else 1
    if isinstance(port, bool) or not isinstance(port, int | np.integer) or not low <= port <= 65535:
        raise ResusError(f"{what} must be an integer in {low}..65535, got {port!r}")
    return int(port)


def pose_to_mm(pose: np.ndarray) -> np.ndarray:
    """A rigid pose with its translation in millimetres (the rotation has no unit)."""
    pose = np.array(pose, dtype=np.float64)
    pose[:3, 3] *= MM_PER_M
    return pose


def pose_from_mm(pose: np.ndarray) -> np.ndarray:
    """The inverse of `pose_to_mm`: a translation in millimetres back to metres."""
    pose = np.array(pose, dtype=np.float64)
    pose[:3, 3] /= MM_PER_M
    return pose


def image_to_reference_mm(probe_to_base: np.ndarray, image_to_probe: np.ndarray) -> np.ndarray:
    """PLUS's ImageToReference: pixel `(col, row, 0, 1)` to the robot base in millimetres."""
    return to_mm(np.asarray(probe_to_base) @ np.asarray(image_to_probe))


def frame_messages(
    frame: SweepFrame,
    image_to_probe: np.ndarray,
    sent_at: float,
    image_name: str = IMAGE_NAME,
    transform_name: str = TRANSFORM_NAME,
) -> bytes:
    """One frame on the wire: TRANSFORM `transform_name` then IMAGE `image_name`, both
    stamped `sent_at` (seconds since 1970, as OpenIGTLink timestamps are)."""
    import pyigtl

    transform = pyigtl.TransformMessage(
        pose_to_mm(frame.probe_to_base), timestamp=sent_at, device_name=transform_name
    )
    image = pyigtl.ImageMessage(
        np.ascontiguousarray(frame.image)[None],
        ijk_to_world_matrix=image_to_reference_mm(frame.probe_to_base, image_to_probe),
        world_coordinate_system="ras",
        timestamp=sent_at,
        device_name=image_name,
    )
    return bytes(transform.pack()) + bytes(image.pack())


def listen(host: str, port: int) -> socket.socket:
    """A listening TCP socket on (host, port); any failure is one line naming both."""
    port = check_port(port, allow_zero=True)
    where = f"{host}:{port}"
    try:
        return socket.create_server((host, port))
    except socket.gaierror:
        raise ResusError(f"OpenIGTLink server: unknown host {host!r}") from None
    except OSError as error:
        if error.errno == errno.EADDRINUSE:
            reason = "the port is already in use (another server?)"
        elif error.errno == errno.EADDRNOTAVAIL:
            reason = f"{host} is not an address of this machine"
        elif error.errno == errno.EACCES:
            reason = "permission denied (ports below 1024 need privileges)"
        else:
            reason = error.strerror or str(error)
        raise ResusError(f"OpenIGTLink server cannot listen on {where}: {reason}") from None


class _Client:
    """One connected client: a bounded queue of packed frames and the thread that sends them."""

    def __init__(self, connection: socket.socket, address: tuple, queue_frames: int) -> None:
        self.connection = connection
        self.address = address
        self.queue: deque[bytes] = deque()
        self.queue_frames = queue_frames
        self.dropped = 0
        self.closing = False
        self.gone = False
        self.wake = threading.Condition()
        connection.settimeout(SEND_TIMEOUT)
        self.thread = threading.Thread(target=self._send_loop, name="igtl-client", daemon=True)
        self.thread.start()

    def push(self, data: bytes) -> None:
        with self.wake:
            if len(self.queue) >= self.queue_frames:
                self.queue.popleft()
                self.dropped += 1
            self.queue.append(data)
            self.wake.notify()

    def _send_loop(self) -> None:
        """Send queued frames; discard whatever the client sends; end when it hangs up, stalls
        or the server closes (after sending what is queued)."""
        try:
            while not self.gone:
                with self.wake:
                    if not self.queue:
                        if self.closing:
                            return
                        self.wake.wait(POLL_INTERVAL)
                    data = self.queue.popleft() if self.queue else None
                if data is not None:
                    self.connection.sendall(data)
                readable, _, _ = select.select([self.connection], [], [], 0)
                if readable and not self.connection.recv(65536):
                    return  # the client hung up
        except OSError:
            return  # reset, broken pipe, or no progress for SEND_TIMEOUT
        finally:
            self.gone = True
            self.connection.close()

    def close(self, linger: float) -> None:
        with self.wake:
            self.closing = True
            self.wake.notify()
        self.thread.join(linger)
        self.gone = True
        self.thread.join(SEND_TIMEOUT + 1.0)
        with contextlib.suppress(OSError):
            self.connection.shutdown(socket.SHUT_RDWR)
        self.connection.close()


class IgtlServer:
    """An OpenIGTLink server streaming every frame appended to it (a `FrameSink`).

    Frames appended while no client is connected are not kept; each client gets the frames
    from the moment it connects. Use as a context manager, or call `close`.
    """

    def __init__(
        self,
        image_to_probe: np.ndarray,
        port: int = DEFAULT_PORT,
        host: str = LOOPBACK,
        *,
        image_name: str = IMAGE_NAME,
        transform_name: str = TRANSFORM_NAME,
        queue_frames: int = QUEUE_FRAMES,
    ) -> None:
        """Listen on `host`:`port` (port 0: any free port, then read `port`)."""
        self.image_to_probe = check_calibration(image_to_probe)
        self.image_name = image_name
        self.transform_name = transform_name
        self.queue_frames = max(1, int(queue_frames))
        self.host = host
        self._listener = listen(host, port)
        self.port: int = self._listener.getsockname()[1]
        """The port listened on (the one picked when 0 was asked for)."""
        self.frames = 0
        """Frames appended so far."""
        self._clients: list[_Client] = []
        self._lock = threading.Lock()
        self._connected = threading.Condition(self._lock)
        self._stopping = threading.Event()
        self._listener.settimeout(POLL_INTERVAL)
        self._accept_thread = threading.Thread(
            target=self._accept_loop, name="igtl-accept", daemon=True
        )
        self._accept_thread.start()

    @property
    def address(self) -> str:
        return f"{self.host}:{self.port}"

    @property
    def clients(self) -> int:
        """Clients connected now."""
        with self._lock:
            return sum(not client.gone for client in self._clients)

    @property
    def dropped(self) -> int:
        """Frames dropped for clients that fell `queue_frames` behind."""
        with self._lock:
            return sum(client.dropped for client in self._clients)

    def _accept_loop(self) -> None:
        while not self._stopping.is_set():
            try:
                connection, address = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return  # the listener was closed
            with self._connected:
                self._clients = [client for client in self._clients if not client.gone]
                self._clients.append(_Client(connection, address, self.queue_frames))
                self._connected.notify_all()

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Wait until a client is connected (True) or `timeout` seconds pass (False)."""
        with self._connected:
            return self._connected.wait_for(
                lambda: any(not client.gone for client in self._clients), timeout
            )

    def send(self, frame: SweepFrame, sent_at: float) -> None:
        """Queue `frame` for every connected client, stamped `sent_at` (s since 1970)."""
        data = frame_messages(
            frame, self.image_to_probe, sent_at, self.image_name, self.transform_name
        )
        with self._lock:
            for client in self._clients:
                if not client.gone:
                    client.push(data)
            self.frames += 1

    def append(self, frame: SweepFrame) -> None:
        """Stream one frame now (the FrameSink interface)."""
        self.send(frame, time.time())

    def close(self, linger: float = 1.0) -> None:
        """Stop listening, give each client up to `linger` s to receive what is queued, then
        disconnect it; safe to call twice."""
        self._stopping.set()
        self._listener.close()
        self._accept_thread.join(SEND_TIMEOUT)
        with self._lock:
            clients, self._clients = self._clients, []
        for client in clients:
            client.close(linger)

    def __enter__(self) -> IgtlServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def stream_sweep(
    sweep: Sweep | str | Path,
    port: int = DEFAULT_PORT,
    loop: bool = False,
    speed: float = 1.0,
    *,
    host: str = LOOPBACK,
    wait_for_client: bool = True,
    stop: threading.Event | None = None,
    on_ready: Callable[[IgtlServer], None] | None = None,
) -> int:
    """Replay a Sweep (or Sweep file) over OpenIGTLink at its recorded timing; return the
    number of frames sent.

    Frame i goes out `(t_i - t_0) / speed` seconds after the first, stamped with that
    scheduled wall-clock time. With `wait_for_client` the replay starts once a client has
    connected; with `loop` it starts over (one median frame interval after the last frame)
    until `stop` is set. `on_ready(server)` is called once the server listens.
    """
    from resus.sweep.io import read_sweep

    if not (isinstance(speed, int | float) and np.isfinite(speed) and speed > 0):
        raise ResusError(f"replay speed must be a positive number, got {speed!r}")
    if not isinstance(sweep, Sweep):
        sweep = read_sweep(sweep)
    stop = stop or threading.Event()
    offsets = (sweep.timestamps - sweep.timestamps[0]) / speed
    gap = float(np.median(np.diff(offsets))) if len(offsets) > 1 else 1.0 / speed
    sent = 0
    with IgtlServer(sweep.image_to_probe, port, host) as server:
        if on_ready is not None:
            on_ready(server)
        while wait_for_client and not server.wait_for_client(POLL_INTERVAL):
            if stop.is_set():
                return sent
        start = time.monotonic()
        wall_start = time.time()
        while True:
            for index, offset in enumerate(offsets):
                if stop.wait(max(0.0, start + offset - time.monotonic())):
                    return sent
                server.send(sweep.frame(index), wall_start + offset)
                sent += 1
            if not loop:
                return sent
            start += float(offsets[-1]) + gap
            wall_start += float(offsets[-1]) + gap
