"""The synthetic probe as a separate device: frames rendered in a worker process.

A synthetic frame takes about 45 ms to render whatever its size (the scatterer lookup has a
fixed cost). Rendered inside a real-time servo loop (`RTDERobot`, 500 Hz) that would stall
the loop for 20 periods per frame and the streamed plan with it. Here, as with a real
scanner, imaging runs beside the robot: when a frame is due, `poll` sends the robot's reported
TCP pose (in the phantom frame) and time to the worker and returns at once; finished frames
come back later, stamped with the robot time of their pose, and the scanner pairs them like
any late frame. While the worker is busy, due frames are skipped, so the frame rate drops to
what rendering sustains instead of frames piling up.

The worker ignores SIGINT: Ctrl-C at a terminal reaches the whole foreground process group,
and a worker that took it died with a KeyboardInterrupt traceback on the user's terminal
beside the scan's one `error: scan stopped: interrupted` line. The scan process handles
Ctrl-C, and ends the worker with `close()`.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import queue
import signal
import threading
from collections.abc import Iterator

import numpy as np

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.probe import Frame, SyntheticProbe
from resus.acquisition.robot import Robot
from resus.errors import ResusError
from resus.execution.executor import available_cores
from sim.phantom import Phantom, PhantomSpec
from sim.robot.scene_config import SceneConfig
from sim.transforms import invert_pose
from sim.ultrasound.simulator import UltrasoundSimulator

START_TIMEOUT = 60.0
"""Seconds to wait for the worker to build the phantom and render its first frame."""


def _render_loop(spec: PhantomSpec, config: SimulatedProbeConfig, requests, results) -> None:
    """Worker: render (time, probe_to_phantom) requests until None arrives, on all cores but
    the two that the servo loop and a local emulator need."""
    import numba

    threads = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # set at runtime
    numba.set_num_threads(max(1, min(threads, available_cores()) - 2))
    simulator = UltrasoundSimulator(Phantom(spec), config.probe, config.settings)
    simulator.render(np.eye(4))  # the first frame loads the compiled kernels
    results.put("ready")
    while (request := requests.get()) is not None:
        time, pose = request
        image, label = simulator.render(pose)
        results.put((time, image, label))


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while a child process starts: the child inherits the ignored signal
    through exec, and Python keeps an ignored SIGINT ignored (no KeyboardInterrupt), from its
    first instruction on. Only the main thread may change signal handlers: a probe opened
    from another thread starts its worker as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class RenderProcessProbe(SyntheticProbe):
    """Synthetic ultrasound of the scene's phantom at `robot`'s reported pose, rendered in a
    worker process; frames are stamped on the robot clock."""

    def __init__(
        self,
        robot: Robot,
        config: SimulatedProbeConfig,
        phantom: Phantom,
        scene: SceneConfig,
    ) -> None:
        """Start the worker and wait until it has rendered a first frame (kernels loaded)."""
        self.robot = robot
        self.config = config
        self.phantom = phantom
        self.geometry = config.probe
        self._base_to_phantom = invert_pose(scene.phantom_to_base)
        context = multiprocessing.get_context("spawn")
        self._requests, self._results = context.Queue(), context.Queue()
        self._worker = context.Process(
            target=_render_loop,
            args=(phantom.spec, config, self._requests, self._results),
            name="probe-render",
            daemon=True,
        )
        with _sigint_ignored():
            self._worker.start()
        try:
            ready = self._results.get(timeout=START_TIMEOUT)
        except queue.Empty:
            ready = None
        if ready != "ready":
            self.close()
            raise ResusError("the synthetic probe's render process did not start")
        self._busy = False
        self._next_frame_time = robot.time()

    def poll(self) -> list[Frame]:
        """Ask for a frame if one is due and the worker is free; return those finished."""
        frames = []
        while True:
            try:
                time, image, label = self._results.get_nowait()
            except queue.Empty:
                break
            frames.append(Frame(time, image, label))
            self._busy = False
        now = self.robot.time()
        if not self._busy and now >= self._next_frame_time - 1e-9:
            pose = self._base_to_phantom @ self.robot.tcp_pose()
            self._requests.put((now, np.ascontiguousarray(pose)))
            self._busy = True
            self._next_frame_time = max(self._next_frame_time + 1 / self.config.frame_rate, now)
        return frames

    def close(self) -> None:
        """Stop the worker; safe to call twice."""
        if self._worker.is_alive():
            self._requests.put(None)
            self._worker.join(timeout=5.0)
            if self._worker.is_alive():
                self._worker.terminate()
                self._worker.join()
