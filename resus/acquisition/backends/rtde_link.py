"""ur_rtde in a process of its own: a crash inside it is a lost link, not the end of a scan.

ur_rtde 1.6.5 reconnects by itself, on its own threads, when the controller drops the link,
and that reconnection crashes the process (SIGSEGV) in a good share of dropped links whatever
the caller does meanwhile (measured against the emulator: 4 of 10 runs, some of them while the
caller only slept). A scan must survive that with every frame it has recorded, so both
interfaces live in a child process (`RTDELink`): the parent sends one request at a time and
sees a child that died as a lost link. After a lost link the child is killed, never asked to
disconnect, so ur_rtde's reconnection has nothing left to race with.

The child also keeps what the parent needs at the moment it asks, so that one request answers
one question: a state packet read consistently (`packet`), the link and safety state together
(`state`), and the control period that `waitPeriod` needs (its start is a C++ clock value that
cannot cross the pipe). What ur_rtde prints from C++ goes to the child's log file, which the
parent logs at DEBUG, so the user sees the one `RobotFault` line instead.
"""

from __future__ import annotations

import contextlib
import faulthandler
import logging
import os
import pickle
import select
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from multiprocessing.connection import Connection
from typing import Any, NamedTuple

from resus.acquisition.robot import RobotFault

log = logging.getLogger(__name__)

RTDE_PORT = 30004
"""The controller's RTDE port: both interfaces' data links."""
CONNECT_TIMEOUT = 60.0
"""Seconds the child gets to start and connect (ur_rtde's own connect gives up sooner)."""
CLOSE_TIMEOUT = 5.0
"""Seconds a healthy child gets to disconnect and exit before it is killed."""
POLL_INTERVAL = 0.05
"""Seconds between checks that the child still lives while a request is answered (a moveL
blocks for as long as the move lasts)."""
PACKET_READ_TIMEOUT = 0.5
"""Seconds `read_packet` may re-read before it gives up: far more than a backlog of queued
packets takes to replay, far less than a scan's watchdog."""
LINK_LOST = "connection to the UR controller lost"
RUNTIME_PLAYING = 2
"""`runtime_state` of a running program."""


class Packet(NamedTuple):
    """One RTDE state packet: timestamp (s) and UR-convention lists."""

    time: float
    pose: list[float]
    """`[x, y, z, rx, ry, rz]` of the TCP."""
    wrench: list[float]
    joints: list[float]


class ControllerState(NamedTuple):
    """The link, program and safety state, read together."""

    link_up: bool
    control_connected: bool
    runtime_state: int
    emergency_stopped: bool
    protective_stopped: bool

    def fault(self) -> str | None:
        """Why the robot cannot move, or None."""
        if not self.link_up:
            return LINK_LOST
        if not self.control_connected:
            return "control connection to the UR controller lost"
        if self.emergency_stopped:
            return "emergency stop"
        if self.protective_stopped:
            return "protective stop"
        if self.runtime_state != RUNTIME_PLAYING:
            return "the control script is not running on the controller"
        return None


LINK_DOWN = ControllerState(False, False, 0, False, False)
"""The state of a link that is gone: nothing on the controller can be read."""


class RTDELink:
    """The parent's end: a child process holding ur_rtde's control and receive interfaces."""

    def __init__(self, host: str, frequency: float) -> None:
        """Start the child and connect; RobotFault when the controller cannot be reached."""
        self.host = host
        log_fd, self._log_path = tempfile.mkstemp(prefix="resus-ur_rtde-", suffix=".log")
        self._log_offset = 0
        ours, theirs = socket.socketpair()
        # A program of its own, not a multiprocessing child: the caller's main module is not
        # imported again (scripts need no `if __name__ == "__main__"` guard), and a session
        # of its own keeps the terminal's Ctrl-C for this process to handle.
        self._process = subprocess.Popen(
            [sys.executable, "-m", __name__, host, repr(frequency), str(theirs.fileno())],
            pass_fds=(theirs.fileno(),),
            stdin=subprocess.DEVNULL,
            stdout=log_fd,
            stderr=log_fd,
            start_new_session=True,
        )
        os.close(log_fd)
        theirs.close()
        # Non-blocking: a message is read only once `poll` shows it, and the child writes
        # each one whole, so a read that would block means a stream out of step (see `call`).
        ours.setblocking(False)
        self._connection = Connection(ours.detach())
        self._requests = 0
        """Requests sent; the child's answer to request n carries n (its connect answer 0)."""
        self.lost = False
        """True once the child died or the link broke: it is killed, not asked, on close."""
        try:
            self._reply(0, CONNECT_TIMEOUT)
        except RuntimeError as error:
            self.close()
            raise RobotFault(f"cannot connect to the UR controller at {host}: {error}") from None
        except RobotFault:
            self.close()
            raise RobotFault(f"cannot connect to the UR controller at {host}") from None

    @property
    def pid(self) -> int:
        """The link process's id (to tell it apart in a process list or a crash report)."""
        return self._process.pid

    def call(self, operation: str, *arguments: object) -> Any:
        """Run one `_Session` operation in the child and return its result. RuntimeError
        with ur_rtde's message when it raised; RobotFault(LINK_LOST) when the child died.

        Ctrl-C (KeyboardInterrupt) can strike anywhere in here: while waiting (a moveL blocks
        for the whole move), but also just after a request went out or an answer came in,
        where Python checks for signals as a call returns. Counting requests in flight broke
        there: a request sent but not counted left its answer to be taken for the next
        request's (a `TypeError` traceback after the scan's own line), and an answer read but
        not counted had the next call wait for an answer that never came (a hung scan). So
        each request carries its number and the answers to interrupted requests are skipped.
        """
        if self.lost:
            raise RobotFault(LINK_LOST)
        self._requests += 1
        try:
            self._connection.send((self._requests, operation, arguments))
        except OSError:
            self._lose(self._ending())
            raise RobotFault(LINK_LOST) from None
        return self._reply(self._requests)

    def _reply(self, number: int, timeout: float | None = None) -> Any:
        """Wait for the answer to request `number` (as long as the child lives), skipping
        those of requests that Ctrl-C interrupted."""
        deadline = None if timeout is None else time.monotonic() + timeout
        answered = None
        while answered != number:
            while not self._connection.poll(POLL_INTERVAL):
                if self._process.poll() is not None:
                    break  # what it sent before it ended is still read; then EOFError
                if deadline is not None and time.monotonic() > deadline:
                    self._lose(f"no answer within {timeout} s")
                    raise RobotFault(LINK_LOST)
            try:
                answered, status, value = self._connection.recv()
            except (EOFError, OSError, pickle.UnpicklingError):  # OSError: out of step
                self._lose(self._ending())
                raise RobotFault(LINK_LOST) from None
        if status == "error":
            self._log_output()
            raise RuntimeError(value)
        return value

    def state(self) -> ControllerState:
        """Link, program and safety state; a dead child or a broken link reads as link down."""
        if self.lost:
            return LINK_DOWN
        try:
            state = ControllerState(*self.call("state"))
        except RobotFault:
            return LINK_DOWN
        if not state.link_up:
            self._lose("the controller closed the link")
        return state

    def checked(self, operation: str, *arguments: object) -> Any:
        """`call`, run only when the controller state read just before it shows no fault
        (one request for both); RobotFault with the fault's reason otherwise."""
        state, result = self.call("checked", operation, *arguments)
        state = ControllerState(*state)
        reason = state.fault()
        if reason is not None:
            if not state.link_up:
                self._lose("the controller closed the link")
            raise RobotFault(reason)
        return result

    def _lose(self, why: str) -> None:
        if not self.lost:
            log.debug("ur_rtde link to %s lost: %s", self.host, why)
        self.lost = True

    def _ending(self) -> str:
        try:
            code = self._process.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            return "ur_rtde's process stopped answering"
        if code < 0:
            return f"ur_rtde's process ended by {signal.Signals(-code).name}"
        return f"ur_rtde's process exited with status {code}"

    def close(self) -> None:
        """Disconnect and end the child; kill it at once after a lost link. Safe twice."""
        if self._process.poll() is None:
            if not self.lost:  # behind a request Ctrl-C interrupted: answered after it
                with contextlib.suppress(OSError, RuntimeError, RobotFault):
                    self._requests += 1
                    self._connection.send((self._requests, "close", ()))
                    self._reply(self._requests, CLOSE_TIMEOUT)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self._process.wait(timeout=CLOSE_TIMEOUT)
            if self._process.poll() is None:
                self._process.kill()
                self._process.wait()
        self._connection.close()
        self._log_output()
        with contextlib.suppress(OSError):
            os.unlink(self._log_path)

    def _log_output(self) -> None:
        """Log at DEBUG what the child printed since last time."""
        try:
            with open(self._log_path, "rb") as file:
                file.seek(self._log_offset)
                text = file.read()
        except OSError:
            return
        self._log_offset += len(text)
        for line in text.decode(errors="replace").splitlines():
            if line.strip():
                log.debug("ur_rtde: %s", line.rstrip())


# -- the child ---------------------------------------------------------------------------


def _serve(connection: Connection, host: str, frequency: float) -> None:
    """Child: connect, then answer requests until "close" or until the parent is gone."""
    faulthandler.enable()  # a crash leaves its traceback in the log
    try:
        session = _Session(host, frequency)
    except Exception as error:  # the process boundary: reported, not lost
        connection.send((0, "error", str(error) or type(error).__name__))
        return
    connection.send((0, "ok", None))
    while True:
        try:
            number, operation, arguments = connection.recv()
        except EOFError:
            break
        if operation == "close":
            session.disconnect()
            connection.send((number, "ok", None))
            break
        try:
            connection.send((number, "ok", getattr(session, operation)(*arguments)))
        except Exception as error:  # the process boundary
            connection.send((number, "error", str(error) or type(error).__name__))


def read_packet(receive: Any, *getters: str) -> tuple[float, list[Any]]:
    """The timestamp and the values of ur_rtde's `getters` (method names of an
    `RTDEReceiveInterface`), all from one state packet.

    ur_rtde's receive thread replaces its packet between any two getter calls, and after a
    stall (a loaded machine) it replays the packets queued meanwhile one after another, so
    several reads in a row can each straddle a replacement: stopping after a fixed number of
    tries and taking the last read could pair one packet's timestamp with a pose a backlog
    later, tens of milliseconds of motion. So the timestamp is read before and after the
    values, and everything read again until the two agree (the controller's timestamps
    strictly increase); a mixed read is never returned. RuntimeError after
    `PACKET_READ_TIMEOUT` of reads that never agreed."""
    deadline = time.monotonic() + PACKET_READ_TIMEOUT
    while True:
        stamp = receive.getTimestamp()
        values = [getattr(receive, getter)() for getter in getters]
        if receive.getTimestamp() == stamp:
            return stamp, values
        if time.monotonic() > deadline:
            raise RuntimeError(
                f"every state packet read for {PACKET_READ_TIMEOUT} s mixed two packets"
            )


class _Session:
    """ur_rtde's two interfaces and what the child keeps between requests."""

    def __init__(self, host: str, frequency: float) -> None:
        import rtde_control
        import rtde_receive

        before = _open_fds()
        self.receive = rtde_receive.RTDEReceiveInterface(host, frequency)
        try:
            self.control = rtde_control.RTDEControlInterface(host, frequency)
        except Exception:
            self.receive.disconnect()
            raise
        self.link = _LinkWatch.opened_since(before, host)
        self.link_up = True
        self.period_start: Any = None

    # Replies are plain tuples: this module runs as the child's __main__, and its NamedTuples
    # would be pickled under that name. The parent makes the Packet / ControllerState.

    def packet(self) -> tuple[float, list[float], list[float], list[float]] | None:
        """The latest state packet, its fields from one packet (read again when a newer one
        arrived between two getter calls); None once the link is down."""
        if not self.check_link():
            return None
        stamp, (pose, wrench, joints) = read_packet(
            self.receive, "getActualTCPPose", "getActualTCPForce", "getActualQ"
        )
        return stamp, pose, wrench, joints

    def state(self) -> tuple[bool, bool, int, bool, bool]:
        """Link, program and safety state (ControllerState's fields). The program state is read
        before the safety state: a script that a protective stop ended shows as the protective
        stop, not as a stopped script."""
        if not self.check_link():
            return (*LINK_DOWN,)  # a plain tuple: see the note on replies above
        receive = self.receive
        runtime_state = receive.getRuntimeState()
        return (
            True,
            self.control.isConnected(),
            runtime_state,
            receive.isEmergencyStopped(),
            receive.isProtectiveStopped(),
        )

    def check_link(self) -> bool:
        """False from the moment the controller's side of the link is gone, seen on the
        sockets or by ur_rtde's receive thread; sticky, as ur_rtde's reconnection is not
        trusted."""
        if self.link_up and (self.link.broken() or not self.receive.isConnected()):
            self.link_up = False
        return self.link_up

    def checked(self, operation: str, *arguments: object) -> tuple[tuple, Any]:
        """The state, and what `operation` returned when the state shows no fault."""
        state = self.state()
        if ControllerState(*state).fault() is not None:
            return state, None
        return state, getattr(self, operation)(*arguments)

    def runtime_state(self) -> int:
        return self.receive.getRuntimeState()

    def command(self, name: str, *arguments: object) -> Any:
        """One RTDEControlInterface call: False when the controller refused it."""
        return getattr(self.control, name)(*arguments)

    def init_period(self) -> None:
        self.period_start = self.control.initPeriod()

    def wait_period(self) -> None:
        """End the open control period (`waitPeriod`) and open the next one."""
        if self.period_start is None:
            self.init_period()
        self.control.waitPeriod(self.period_start)
        self.init_period()

    def disconnect(self) -> None:
        for interface in (self.control, self.receive):
            with contextlib.suppress(RuntimeError):
                interface.disconnect()


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


if __name__ == "__main__":
    _serve(Connection(int(sys.argv[3])), sys.argv[1], float(sys.argv[2]))
