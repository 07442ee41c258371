"""The emulator's network side: dashboard (29999), RTDE (30004) and script (30003) servers.

One thread runs the control loop: every control period (2 ms) it cycles the controller and
sends each started RTDE output recipe its data packet, so simulated time advances with
wall-clock time. Every connection has its own reader thread. The loop never waits on a
client: data packets are sent without blocking, and a client whose receive buffer is full
(seconds behind) is disconnected rather than allowed to stall everyone else.
"""

from __future__ import annotations

import contextlib
import logging
import random
import re
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

from sim.rtde import dashboard, protocol
from sim.rtde.controller import Controller
from sim.rtde.faults import FaultPlan
from sim.rtde.protocol import Recipe

log = logging.getLogger("sim.rtde")

DASHBOARD_PORT, SCRIPT_PORT, RTDE_PORT = 29999, 30003, 30004
SOCKET_TIMEOUT = 1.0
"""Timeout of blocking socket calls (handshake replies, reader wake-ups) (s)."""
MAX_LAG = 0.05
"""When the loop falls this far behind wall-clock time it stops catching up (s)."""
_PROGRAM = re.compile(r"^def\s+\w+\s*\(\s*\)\s*:.*?^end[ \t]*$", re.MULTILINE | re.DOTALL)


@dataclass(frozen=True)
class Ports:
    """The three TCP ports, each `base` above UR's standard one."""

    base: int = 0

    def __post_init__(self) -> None:
        low, high = DASHBOARD_PORT + self.base, RTDE_PORT + self.base
        if not (low >= 1 and high <= 65535):
            raise ValueError(
                f"port base {self.base} puts the ports at {low}-{high}, outside 1-65535 "
                f"(the base must lie in {1 - DASHBOARD_PORT}..{65535 - RTDE_PORT})"
            )

    @property
    def dashboard(self) -> int:
        return DASHBOARD_PORT + self.base

    @property
    def rtde(self) -> int:
        return RTDE_PORT + self.base

    @property
    def script(self) -> int:
        return SCRIPT_PORT + self.base


def _recv_exact(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        try:
            chunk = sock.recv(size - len(data))
        except TimeoutError:
            continue
        if not chunk:
            raise ConnectionError("peer closed")
        data += chunk
    return data


class RtdeSession:
    """One RTDE client: its recipes, its start/pause state and its (optionally delayed) sends."""

    def __init__(self, sock: socket.socket, emulator: Emulator) -> None:
        self.sock, self.emulator = sock, emulator
        self.send_lock = threading.Lock()
        self.outputs: list[tuple[Recipe, int]] = []
        self.inputs: dict[int, Recipe] = {}
        self.started = False
        self.closed = False
        self._queue: deque[tuple[float, bytes]] = deque()
        self._queued = threading.Condition()
        faults = emulator.faults
        self._random = random.Random(faults.seed)
        if faults.delays_data:
            threading.Thread(target=self._delayed_sender, daemon=True).start()

    def send(self, data: bytes) -> None:
        """A reply: blocking (from this session's reader thread)."""
        try:
            with self.send_lock:
                self.sock.sendall(data)
        except OSError as error:
            self.close(f"send failed ({error})")

    def send_data(self, data: bytes) -> None:
        """A data packet: never blocks the control loop (a partial packet ends the session)."""
        try:
            with self.send_lock:
                sent = self.sock.send(data, socket.MSG_DONTWAIT)
        except BlockingIOError:
            sent = 0
        except OSError as error:
            self.close(f"send failed ({error})")
            return
        if sent != len(data):
            self.close("client stopped reading its data")

    def publish(self, tick: int, controller: Controller) -> None:
        """Send each output recipe due at this tick."""
        if not self.started or self.closed:
            return
        for recipe, decimation in self.outputs:
            if tick % decimation:
                continue
            data = recipe.pack({name: controller.output_value(name) for name in recipe.names})
            if not self.emulator.faults.delays_data:
                self.send_data(data)
                continue
            faults = self.emulator.faults
            due = time.perf_counter() + faults.latency + self._random.uniform(0.0, faults.jitter)
            with self._queued:
                if self._queue:
                    due = max(due, self._queue[-1][0])
                self._queue.append((due, data))
                self._queued.notify()

    def _delayed_sender(self) -> None:
        while not self.closed:
            with self._queued:
                while not self._queue and not self.closed:
                    self._queued.wait(0.1)
                if self.closed:
                    return
                due, data = self._queue[0]
            wait = due - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            with self._queued:
                self._queue.popleft()
            self.send_data(data)

    def close(self, reason: str) -> None:
        if self.closed:
            return
        self.closed = True
        log.info("rtde client disconnected: %s", reason)
        self.emulator.release_inputs(self)
        with contextlib.suppress(OSError):
            self.sock.close()

    def serve(self) -> None:
        """Answer packets until the client leaves."""
        try:
            while not self.closed:
                size, kind = protocol.HEADER.unpack(_recv_exact(self.sock, protocol.HEADER.size))
                payload = _recv_exact(self.sock, size - protocol.HEADER.size)
                self._handle(kind, payload)
        except (ConnectionError, OSError) as error:
            self.close(str(error))

    def _handle(self, kind: int, payload: bytes) -> None:
        controller = self.emulator.controller
        if kind == protocol.DATA_PACKAGE:
            recipe = self.inputs.get(payload[0])
            if recipe is None:
                log.warning("data packet for unknown input recipe %d ignored", payload[0])
                return
            controller.write_inputs(recipe.unpack(payload))
        elif kind == protocol.REQUEST_PROTOCOL_VERSION:
            (version,) = struct.unpack(">H", payload)
            accepted = version <= protocol.PROTOCOL_VERSION
            self.send(protocol.packet(kind, bytes([accepted])))
        elif kind == protocol.GET_URCONTROL_VERSION:
            self.send(protocol.packet(kind, struct.pack(">4I", *controller.settings.version)))
        elif kind == protocol.SETUP_OUTPUTS:
            self._setup_outputs(payload)
        elif kind == protocol.SETUP_INPUTS:
            self._setup_inputs(payload)
        elif kind == protocol.START:
            with self.send_lock:
                self.sock.sendall(protocol.packet(kind, b"\x01"))
                self.started = True
        elif kind == protocol.PAUSE:
            with self.send_lock:
                self.started = False
                self.sock.sendall(protocol.packet(kind, b"\x01"))
        else:
            log.warning("RTDE packet type %r not handled", chr(kind))

    def _setup_outputs(self, payload: bytes) -> None:
        (frequency,) = struct.unpack(">d", payload[:8])
        names = protocol.split_names(payload[8:])
        types = tuple(protocol.output_type(name) or "NOT_FOUND" for name in names)
        if "NOT_FOUND" in types or not 0 < frequency <= 500:
            missing = [n for n, t in zip(names, types, strict=True) if t == "NOT_FOUND"]
            log.warning("output recipe refused: unknown %s, frequency %g Hz", missing, frequency)
            self.send(protocol.packet(protocol.SETUP_OUTPUTS, b"\x00" + ",".join(types).encode()))
            return
        recipe_id = len(self.outputs) + 1
        decimation = max(1, round(1.0 / (frequency * self.emulator.controller.arm.control_period)))
        self.outputs.append((Recipe(recipe_id, names, types), decimation))
        self.send(
            protocol.packet(protocol.SETUP_OUTPUTS, bytes([recipe_id]) + ",".join(types).encode())
        )

    def _setup_inputs(self, payload: bytes) -> None:
        names = protocol.split_names(payload)
        types = [protocol.input_type(name) or "NOT_FOUND" for name in names]
        types = [
            "IN_USE" if self.emulator.claim_input(name, self) is False else kind
            for name, kind in zip(names, types, strict=True)
        ]
        if "NOT_FOUND" in types or "IN_USE" in types:
            log.warning("input recipe refused: %s", dict(zip(names, types, strict=True)))
            self.send(protocol.packet(protocol.SETUP_INPUTS, b"\x00" + ",".join(types).encode()))
            return
        recipe_id = len(self.inputs) + 1
        self.inputs[recipe_id] = Recipe(recipe_id, names, tuple(types))
        self.send(
            protocol.packet(protocol.SETUP_INPUTS, bytes([recipe_id]) + ",".join(types).encode())
        )


class Emulator:
    """The servers and the control loop around one `Controller`."""

    def __init__(
        self,
        controller: Controller,
        host: str = "127.0.0.1",
        ports: Ports = Ports(),
        faults: FaultPlan | None = None,
    ) -> None:
        self.controller, self.host, self.ports = controller, host, ports
        self.faults = faults or FaultPlan()
        self._listeners: list[socket.socket] = []
        self._connections: set[socket.socket] = set()
        self._sessions: list[RtdeSession] = []
        self._input_owners: dict[str, RtdeSession] = {}
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._dropped = False

    # -- listeners and connections -------------------------------------------------

    def open(self) -> None:
        """Bind the three servers (raises OSError when an address or port is taken)."""
        handlers = (
            (self.ports.dashboard, self._serve_dashboard),
            (self.ports.rtde, self._serve_rtde),
            (self.ports.script, self._serve_script),
        )
        listeners = []
        try:
            for port, handler in handlers:
                listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                listener.bind((self.host, port))
                listener.listen(8)
                listeners.append((listener, handler))
        except OSError:
            for listener, _ in listeners:
                listener.close()
            raise
        for listener, handler in listeners:
            self._listeners.append(listener)
            threading.Thread(target=self._accept, args=(listener, handler), daemon=True).start()

    def _accept(self, listener: socket.socket, handler) -> None:
        while not self._stopping.is_set():
            try:
                sock, _ = listener.accept()
            except OSError:
                return
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.settimeout(SOCKET_TIMEOUT)
            with self._lock:
                self._connections.add(sock)
            threading.Thread(target=self._run_handler, args=(handler, sock), daemon=True).start()

    def _run_handler(self, handler, sock: socket.socket) -> None:
        try:
            handler(sock)
        finally:
            with self._lock:
                self._connections.discard(sock)
            sock.close()

    def claim_input(self, name: str, session: RtdeSession) -> bool:
        """Reserve an input variable for one client; False when another client holds it."""
        with self._lock:
            owner = self._input_owners.setdefault(name, session)
            return owner is session

    def release_inputs(self, session: RtdeSession) -> None:
        with self._lock:
            self._input_owners = {n: s for n, s in self._input_owners.items() if s is not session}
            if session in self._sessions:
                self._sessions.remove(session)

    # -- the three protocols ----------------------------------------------------------

    def _serve_rtde(self, sock: socket.socket) -> None:
        session = RtdeSession(sock, self)
        with self._lock:
            self._sessions.append(session)
        session.serve()

    def _received(self, sock: socket.socket, size: int) -> Iterator[bytes]:
        """What a client sends, up to `size` bytes a read, until it closes the connection, the
        connection fails or the server stops."""
        while not self._stopping.is_set():
            try:
                chunk = sock.recv(size)
            except TimeoutError:
                continue
            except OSError:
                return
            if not chunk:
                return
            yield chunk

    def _serve_dashboard(self, sock: socket.socket) -> None:
        sock.sendall((dashboard.WELCOME + "\n").encode())
        buffer = b""
        for chunk in self._received(sock, 4096):
            buffer += chunk
            while b"\n" in buffer:
                line, buffer = buffer.split(b"\n", 1)
                answer, close = dashboard.reply(self.controller, line.decode(errors="replace"))
                sock.sendall((answer + "\n").encode())
                if close:
                    return

    def _serve_script(self, sock: socket.socket) -> None:
        text = ""
        for chunk in self._received(sock, 65536):
            text += chunk.decode(errors="replace")
            while (match := _PROGRAM.search(text)) is not None:
                log.info("script port: program of %d bytes received", len(match.group(0)))
                self.controller.start_program(match.group(0))
                text = text[match.end() :]

    # -- the control loop --------------------------------------------------------------

    def run(self) -> None:
        """Cycle the controller every control period until `stop()`."""
        period = self.controller.arm.control_period
        next_time = time.perf_counter()
        tick = 0
        protective_stop_done = False
        while not self._stopping.is_set():
            self.controller.cycle()
            now = self.controller.arm.time()
            started = self.controller.motion_started_at
            if now >= self.faults.protective_stop_time(started) and not protective_stop_done:
                protective_stop_done = True
                self.controller.protective_stop(
                    f"injected fault at t={now:.3f} s (monotonic {time.monotonic():.6f})"
                )
            self._apply_drop(now, started)
            for session in list(self._sessions):
                session.publish(tick, self.controller)
            tick += 1
            next_time += period
            delay = next_time - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            elif delay < -MAX_LAG:
                log.warning(
                    "control loop %.0f ms behind the wall clock: not catching up", -delay * 1e3
                )
                next_time = time.perf_counter()

    def _apply_drop(self, now: float, motion_started: float | None) -> None:
        refusing = self.faults.refusing(now, motion_started)
        if refusing and not self._dropped:
            self._dropped = True
            log.warning(  # before closing: a client that sees the drop finds it in the log
                "dropping every connection: injected fault at t=%.3f s (monotonic %.6f)",
                now,
                time.monotonic(),
            )
            self._close_all()
        elif self._dropped and not refusing:
            self._dropped = False
            log.warning("accepting connections again at t=%.3f s", now)
            self.open()

    def _close_all(self) -> None:
        for listener in self._listeners:
            listener.close()
        self._listeners.clear()
        with self._lock:
            connections = list(self._connections)
        for sock in connections:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()

    def stop(self) -> None:
        """End the loop and close every socket."""
        self._stopping.set()
        self._close_all()
