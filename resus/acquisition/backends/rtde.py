"""A UR robot through ur_rtde: the real UR3e, or the RTDE emulator on 127.0.0.1.

`RTDERobot` drives the controller with `rtde_control.RTDEControlInterface` and reads it
with `rtde_receive.RTDEReceiveInterface`. Poses are converted to UR's `[x, y, z, rx, ry, rz]`
here and nowhere else. Streaming follows ur_rtde's fixed-rate pattern: `servo_linear` opens
a control period with `initPeriod()`, `wait_period` closes it with `waitPeriod()`.

Readings: ur_rtde's receive thread replaces its state packet between any two getter calls, so
the timestamp, pose, wrench and joints are read from one packet together (read again when a
newer packet arrived in between), and every reading returns that packet's values until the
next period (`wait_period`), command or READING_HOLD: a cycle's readings describe one instant,
as the simulated robot's do between two periods, and a pose recorded against a timestamp is
the pose at it, however late the calling thread runs on a loaded machine.

Faults: every command checks the link and the safety state first, and a command the
controller refuses raises `RobotFault` with the controller's reason. A link the controller
closed is seen on its sockets at once (`_LinkWatch`), before ur_rtde's own threads notice it.
ur_rtde holds Python's GIL while it blocks (moveL), so Ctrl-C is handled when the call
returns; `close()` (also on leaving the `with` block, whatever the exit) then stops the
servo, stops the control script and disconnects.

What ur_rtde prints from C++ on the process's stdout and stderr (`connect: Connection
refused`, `RTDE control script is not running!`) is captured around its calls and the wait
after a lost link, and logged at DEBUG on this module's logger, so the user sees the one
`RobotFault` line instead. (Its threads print the moment a link drops too; what lands outside
those calls still reaches the console.)
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import select
import socket
import stat
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from resus.acquisition.robot import Robot, RobotFault
from sim.transforms import is_rigid, pose_from_ur, pose_to_ur

log = logging.getLogger(__name__)

RUNTIME_PLAYING = 2
"""`runtime_state` of a running program."""
RTDE_PORT = 30004
"""The controller's RTDE port: both interfaces' data links."""
SCRIPT_START_TIMEOUT = 2.0
"""Seconds the receive stream gets after connecting to show the control script running:
ur_rtde waited for it on the control interface's own stream, which may be ahead."""
REFUSAL_WAIT = 0.25
"""Seconds to wait for the reason of a refused command to show on the receive stream, which
may lag the control stream that saw the refusal."""
LINK_SETTLE = 2.0
"""Seconds `close` and `reconnect` wait after a lost link before disconnecting: ur_rtde 1.6.5
reconnects on its own after a dropped link, and disconnecting while that reconnection runs
crashes the process (segfault), so it is given time to finish or give up."""
READING_TRIES = 5
"""Reads of one state packet before taking a mixed one (a new packet arrives every 2 ms and
a read takes microseconds, so a second try is rare and a fifth one never needed)."""
READING_HOLD = 0.1
"""Longest time (s) for which readings return the packet they last read when no period ends
and no command is sent: long enough that a preempted caller still pairs a cycle's readings,
short enough that a caller polling without `wait_period` sees the robot move."""


@dataclass(frozen=True)
class _Readings:
    """One RTDE state packet's timestamp, TCP pose (4x4), TCP wrench and joints."""

    time: float
    pose: np.ndarray
    wrench: np.ndarray
    joints: np.ndarray
    taken_at: float
    """`time.monotonic()` when it was read."""


@dataclass(frozen=True)
class RTDERobotConfig:
    """How to reach and drive a UR controller over RTDE."""

    host: str = "127.0.0.1"
    """Controller address (the emulator listens on 127.0.0.1 by default)."""
    frequency: float = 500.0
    """RTDE rate (Hz): 500 for e-Series, 125 for CB3."""
    tcp_offset: np.ndarray | None = None
    """TCP pose in the flange frame (4x4, m): the probe face centre, z into the tissue.
    None keeps the TCP configured on the controller (PolyScope installation, or the
    simulated probe's in the emulator)."""
    servo_lookahead: float = 0.1
    """servoL lookahead time (s, UR range 0.03-0.2): smooths the streamed path."""
    servo_gain: float = 300.0
    """servoL proportional gain (UR range 100-2000)."""
    force_speed_limit: float = 0.05
    """Highest TCP speed along the compliant axis in force mode (m/s)."""
    stop_deceleration: float = 2.0
    """Deceleration of `stop()` (m/s^2)."""

    def __post_init__(self) -> None:
        if self.tcp_offset is not None:
            offset = np.asarray(self.tcp_offset, dtype=np.float64)
            if offset.shape != (4, 4) or not is_rigid(offset):
                raise ValueError(
                    "tcp_offset must be a rigid 4x4 pose of the TCP in the flange frame"
                )
            object.__setattr__(self, "tcp_offset", offset)
        if not 0 < self.frequency <= 500:
            raise ValueError(f"frequency must be in (0, 500] Hz, got {self.frequency}")
        if not 0.03 <= self.servo_lookahead <= 0.2:
            raise ValueError(
                f"servo_lookahead must be in [0.03, 0.2] s, got {self.servo_lookahead}"
            )
        if not 100 <= self.servo_gain <= 2000:
            raise ValueError(f"servo_gain must be in [100, 2000], got {self.servo_gain}")


class RTDERobot(Robot):
    """A UR arm behind ur_rtde's control and receive interfaces."""

    def __init__(self, config: RTDERobotConfig = RTDERobotConfig()) -> None:
        self.config = config
        self.control_period = 1.0 / config.frequency
        # ur_rtde's RTDEControlInterface / RTDEReceiveInterface (untyped); None while closed
        self._control: Any = None
        self._receive: Any = None
        self._cycle_start = None
        self._link = _LinkWatch([])
        self._link_lost_at: float | None = None
        self._readings: _Readings | None = None
        self._connect()

    # -- connection --------------------------------------------------------------------

    def _connect(self) -> None:
        import rtde_control
        import rtde_receive

        host = self.config.host
        try:
            with _native_output():
                before = _open_fds()
                self._receive = rtde_receive.RTDEReceiveInterface(host, self.config.frequency)
                self._control = rtde_control.RTDEControlInterface(host, self.config.frequency)
                self._link = _LinkWatch.opened_since(before, host)
        except RuntimeError as error:
            self._disconnect()
            raise RobotFault(f"cannot connect to the UR controller at {host}: {error}") from None
        self._await_script()
        offset = self.config.tcp_offset
        if offset is not None:
            with _native_output():
                accepted = self._control.setTcp(pose_to_ur(offset).tolist())
            if not accepted:
                self.close()
                raise RobotFault(f"the UR controller at {host} refused the TCP offset")

    def _await_script(self) -> None:
        """Give the receive stream time to show the control script running: right after
        connecting it may still hold a packet from before the script started, which `fault()`
        would take for a stopped script."""
        deadline = time.monotonic() + SCRIPT_START_TIMEOUT
        while self._receive.getRuntimeState() != RUNTIME_PLAYING and time.monotonic() < deadline:
            time.sleep(self.control_period)

    def reconnect(self) -> None:
        """Drop both interfaces and connect again (after a lost link or a stopped script)."""
        self._disconnect()
        self._connect()

    def _disconnect(self) -> None:
        """Disconnect both interfaces; after a lost link, once ur_rtde's own reconnection has
        had LINK_SETTLE to finish (what it prints meanwhile is captured too)."""
        with _native_output():
            if self._link_lost_at is not None and self._control is not None:
                time.sleep(max(0.0, self._link_lost_at + LINK_SETTLE - time.monotonic()))
            for interface in (self._control, self._receive):
                if interface is not None:
                    with contextlib.suppress(RuntimeError):
                        interface.disconnect()
            self._control = self._receive = None  # their destructors disconnect once more
        self._link = _LinkWatch([])
        self._link_lost_at = None
        self._readings = None
        self._cycle_start = None

    def close(self) -> None:
        """Stop servoing, stop the control script, disconnect; safe to call twice. After a
        lost link it first lets ur_rtde's own reconnection settle (see LINK_SETTLE)."""
        if self._control is not None and self._receive is not None and self.fault() is None:
            with _native_output():
                self._control.servoStop(self.config.stop_deceleration)
                self._control.stopScript()
        self._disconnect()

    # -- readings ----------------------------------------------------------------------

    def _reader(self):
        if self._receive is None or not self._link_up():
            raise RobotFault(self.fault() or "connection to the UR controller lost")
        return self._receive

    def _packet(self) -> _Readings:
        """The held state packet, or the latest one, read consistently (see the module doc)."""
        readings = self._readings
        if readings is not None and time.monotonic() - readings.taken_at <= READING_HOLD:
            return readings
        receive = self._reader()
        for _ in range(READING_TRIES):
            stamp = receive.getTimestamp()
            pose = receive.getActualTCPPose()
            wrench = receive.getActualTCPForce()
            joints = receive.getActualQ()
            if receive.getTimestamp() == stamp:
                break
        self._readings = _Readings(
            float(stamp),
            pose_from_ur(np.array(pose)),
            np.array(wrench),
            np.array(joints),
            time.monotonic(),
        )
        return self._readings

    def tcp_pose(self) -> np.ndarray:
        return self._packet().pose.copy()

    def joint_positions(self) -> np.ndarray:
        return self._packet().joints.copy()

    def tcp_wrench(self) -> np.ndarray:
        return self._packet().wrench.copy()

    def time(self) -> float:
        return self._packet().time

    def fault(self) -> str | None:
        """Why the robot cannot move. The receive stream's packet may change between two
        getter calls, so the program state is read before the safety state: a script that a
        protective stop ended shows as the protective stop, not as a stopped script."""
        receive, control = self._receive, self._control
        if receive is None or control is None or not self._link_up():
            return "connection to the UR controller lost"
        if not control.isConnected():
            return "control connection to the UR controller lost"
        playing = receive.getRuntimeState() == RUNTIME_PLAYING
        if receive.isEmergencyStopped():
            return "emergency stop"
        if receive.isProtectiveStopped():
            return "protective stop"
        if not playing:
            return "the control script is not running on the controller"
        return None

    def _link_up(self) -> bool:
        """False from the moment the controller's side of the link is gone (sticky until
        `reconnect`): seen on the sockets themselves, or by ur_rtde's receive thread."""
        if self._link_lost_at is None and (self._link.broken() or not self._receive.isConnected()):
            self._link_lost_at = time.monotonic()
        return self._link_lost_at is None

    # -- commands ----------------------------------------------------------------------

    def _command(self, name: str, *arguments: object) -> None:
        """Send one command; RobotFault when it fails or the controller refuses it.

        ur_rtde returns False for a refused command (None for void ones) and raises
        RuntimeError when the link breaks under it.
        """
        control = self._controller()
        try:
            with _native_output():
                accepted = getattr(control, name)(*arguments)
        except RuntimeError as error:
            raise RobotFault(f"{name} failed: {self.fault() or error}") from None
        finally:
            self._readings = None
        if accepted is False:
            raise RobotFault(f"{name} refused: {self._refusal_reason()}")

    def _refusal_reason(self) -> str:
        """Why the controller refused a command. The receive stream may lag the control
        stream that saw the refusal, so it gets REFUSAL_WAIT to catch up."""
        deadline = time.monotonic() + REFUSAL_WAIT
        while True:
            reason = self.fault()
            if reason is not None:
                return reason
            if time.monotonic() > deadline:
                return "the controller returned failure"
            time.sleep(self.control_period)

    def _controller(self):
        reason = self.fault()
        if reason is not None:
            raise RobotFault(reason)
        return self._control

    def _wait(self, control, cycle_start) -> None:
        """One `waitPeriod`: the next readings are of a newer packet."""
        with _native_output():
            control.waitPeriod(cycle_start)
        self._readings = None

    def move_linear(self, pose: np.ndarray, speed: float, acceleration: float) -> None:
        self._command("moveL", pose_to_ur(pose).tolist(), speed, acceleration, False)

    def servo_linear(self, pose: np.ndarray) -> None:
        if self._cycle_start is None:
            self._cycle_start = self._controller().initPeriod()
        config = self.config
        self._command(
            "servoL",
            pose_to_ur(pose).tolist(),
            0.5,  # speed and acceleration: ignored by UR's servoL, required by the API
            0.5,
            self.control_period,
            config.servo_lookahead,
            config.servo_gain,
        )

    def wait_period(self) -> None:
        control = self._controller()
        if self._cycle_start is None:
            self._cycle_start = control.initPeriod()
        self._wait(control, self._cycle_start)
        self._cycle_start = control.initPeriod()

    def force_mode(self, force: float) -> None:
        """forceMode type 2 in the current TCP frame: compliant along z only."""
        task_frame = pose_to_ur(self.tcp_pose()).tolist()
        limit = self.config.force_speed_limit
        wrench = [0.0, 0.0, float(force), 0.0, 0.0, 0.0]
        limits = [limit, limit, limit, 0.17, 0.17, 0.17]
        self._command("forceMode", task_frame, [0, 0, 1, 0, 0, 0], wrench, 2, limits)
        # Streamed commands share input_int_register_0: give the controller two cycles to
        # read forceMode before the next servoL overwrites it.
        control = self._controller()
        for _ in range(2):
            self._wait(control, control.initPeriod())

    def force_mode_stop(self) -> None:
        self._command("forceModeStop")

    def stop(self) -> None:
        """End servoing and speed commands and brake any move (servoStop, speedStop, stopL)."""
        deceleration = self.config.stop_deceleration
        self._command("servoStop", deceleration)
        self._command("speedStop", deceleration)
        self._command("stopL", deceleration, False)
        self._cycle_start = None


class _LinkWatch:
    """The controller's RTDE sockets as the kernel sees them.

    ur_rtde learns that the controller closed the link only when its receive thread next
    reads the socket, which on a loaded machine can be tens of milliseconds later, and a
    command sent meanwhile blocks in ur_rtde's own reconnection attempt. The kernel knows at
    once: a peer's close shows as POLLRDHUP (or HUP/ERR) on the socket, and a socket that
    ur_rtde itself has closed or replaced no longer has its inode behind the descriptor.
    Linux only; elsewhere the watch is empty and ur_rtde's `isConnected()` decides alone.
    """

    def __init__(self, sockets: list[tuple[int, int]]) -> None:
        self._sockets = sockets
        """(file descriptor, socket inode) of each watched socket."""
        self._poll = select.poll()
        for fd, _ in sockets:
            self._poll.register(fd, select.POLLRDHUP)

    @classmethod
    def opened_since(cls, before: set[int] | None, host: str) -> _LinkWatch:
        """The RTDE sockets to `host` among the descriptors opened since `before`."""
        if before is None or not hasattr(select, "POLLRDHUP"):
            return cls([])
        try:
            address = socket.gethostbyname(host)
        except OSError:
            return cls([])
        found = []
        for fd in sorted((_open_fds() or set()) - before):
            try:
                info = os.fstat(fd)
                if not stat.S_ISSOCK(info.st_mode):
                    continue
                with socket.socket(fileno=os.dup(fd)) as duplicate:  # closes only the dup
                    peer = duplicate.getpeername()
            except OSError:
                continue
            if isinstance(peer, tuple) and peer[:2] == (address, RTDE_PORT):
                found.append((fd, info.st_ino))
        return cls(found)

    def broken(self) -> bool:
        """True when the controller closed a watched link or ur_rtde dropped its socket."""
        for fd, inode in self._sockets:
            try:
                if os.fstat(fd).st_ino != inode:
                    return True
            except OSError:
                return True
        return bool(self._sockets and self._poll.poll(0))


def _open_fds() -> set[int] | None:
    """This process's open file descriptors, or None where /proc does not list them."""
    try:
        return {int(name) for name in os.listdir("/proc/self/fd")}
    except OSError:
        return None


_capture_lock = threading.RLock()
_capture_depth = 0
_capture_fd: int | None = None
"""The file that receives the captured output, made on first use and removed at exit. It has
a name so that what a crash or a hang guard's traceback wrote into it can still be read."""


@contextlib.contextmanager
def _native_output() -> Iterator[None]:
    """Send what C code prints on file descriptors 1 and 2 inside the block to a file, and
    log it at DEBUG afterwards: ur_rtde reports link and script trouble there in its own
    words, beside the `RobotFault` that says it in one line. Python's buffered streams are
    flushed first so nothing of theirs lands in the file. Nested blocks capture once."""
    global _capture_depth, _capture_fd
    with _capture_lock:
        if _capture_depth:
            _capture_depth += 1
            try:
                yield
            finally:
                _capture_depth -= 1
            return
        if _capture_fd is None:
            _capture_fd, path = tempfile.mkstemp(prefix="resus-ur_rtde-", suffix=".log")
            atexit.register(_remove, path)
            log.debug("ur_rtde's console output is captured in %s", path)
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(AttributeError, OSError, ValueError):
                stream.flush()
        capture = _capture_fd
        saved = (os.dup(1), os.dup(2))
        os.dup2(capture, 1)
        os.dup2(capture, 2)
        _capture_depth = 1
        try:
            yield
        finally:
            _capture_depth = 0
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            _log_captured(capture)


def _remove(path: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)


def _log_captured(fd: int) -> None:
    """Log and empty the capture file."""
    size = os.fstat(fd).st_size
    if not size:
        return
    text = os.pread(fd, size, 0).decode(errors="replace")
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    for line in text.splitlines():
        if line.strip():
            log.debug("ur_rtde: %s", line.rstrip())
