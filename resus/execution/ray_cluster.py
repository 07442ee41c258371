"""The Ray engine: every unit a Ray task, on a cluster or on a Ray started on this machine.

With an address the executor joins a running cluster: "auto" (a cluster this machine belongs
to, e.g. run on the head node), "ray://HOST:10001" (Ray Client, from any machine that reaches
the head) or "HOST:6379" (the head's GCS). Without one it starts a Ray of its own when the
first unit needs it, bound to 127.0.0.1 with no dashboard, so nothing is exposed to the
network, and stops it when the executor closes. A Ray already running in this process (a
test's, a notebook's) is used as it is and left running.

Each unit asks Ray for its `Resources` (`num_cpus`, `num_gpus` as a fraction); Ray retries a
unit whose worker or node was lost (`RETRIES` times). A unit's own exception is not retried:
it ends the map, as with the local engine.
"""

from __future__ import annotations

import logging
import os
import socket
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

from resus.errors import ResusError
from resus.execution.executor import Executor, Resources, WorkerLost, grant_cpus

Item = TypeVar("Item")
Result = TypeVar("Result")

RETRIES = 3
"""Times Ray reruns a unit whose worker process or node died."""
CONNECT_TIMEOUT = 5.0
"""Seconds to wait for a TCP answer from a cluster address before refusing it."""
LOOPBACK_ONLY = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
"""Ray's switch for single-machine mode: "0" binds every Ray service to 127.0.0.1 (the
default on macOS and Windows; on Linux Ray otherwise listens on all interfaces)."""
ADDRESS_FORMS = "auto, ray://HOST:PORT or HOST:PORT"


def check_address(address: str | None) -> None:
    """Refuse an address of the wrong form, or one where nothing answers (a TCP connect, so
    a typo fails in seconds rather than after Ray's own minute of retries)."""
    if address is None or address == "auto":
        return
    scheme, separator, rest = address.partition("://")
    host, colon, port = (rest if separator else address).rpartition(":")
    if (separator and scheme != "ray") or not (colon and host and port.isdecimal()):
        raise ResusError(f"RayExecutor address must be {ADDRESS_FORMS}, got {address!r}")
    if not 0 < int(port) < 65536:
        raise ResusError(f"RayExecutor address port must be in 1..65535, got {address!r}")
    try:
        socket.create_connection((host.strip("[]"), int(port)), CONNECT_TIMEOUT).close()
    except OSError as error:
        reason = error.strerror or str(error) or type(error).__name__
        raise ResusError(f"cannot reach a Ray cluster at {address!r}: {reason}") from None


@contextmanager
def _loopback_only() -> Iterator[None]:
    """Ray in single-machine mode while it starts: its services (started now, inheriting the
    environment) bind 127.0.0.1; this process's Ray reads the switch it cached at import."""
    from ray._private import ray_constants

    saved_variable, saved_switch = os.environ.get(LOOPBACK_ONLY), ray_constants.ENABLE_RAY_CLUSTER
    os.environ[LOOPBACK_ONLY] = "0"
    ray_constants.ENABLE_RAY_CLUSTER = False
    try:
        yield
    finally:
        ray_constants.ENABLE_RAY_CLUSTER = saved_switch
        if saved_variable is None:
            del os.environ[LOOPBACK_ONLY]
        else:
            os.environ[LOOPBACK_ONLY] = saved_variable


def start_local_ray(cpus: int) -> None:
    """Start a Ray of `cpus` CPUs on this machine for this process: every service on
    127.0.0.1, no dashboard, Ray's own messages at warning level and above only."""
    import ray

    with _loopback_only():
        try:
            ray.init(
                num_cpus=cpus,
                include_dashboard=False,
                logging_level=logging.WARNING,
                log_to_driver=False,
            )
        except (ConnectionError, RuntimeError, ValueError) as error:
            raise ResusError(f"cannot start a local Ray: {_first_line(error)}") from None


def _first_line(error: BaseException) -> str:
    return (str(error).strip().splitlines() or [type(error).__name__])[0]


def _run_unit(function: Callable[[Any], Any], item: Any, cpus: int) -> Any:
    """A Ray task: one unit, told how many cores Ray granted it."""
    grant_cpus(cpus)
    return function(item)


class RayExecutor(Executor):
    """Units as Ray tasks; a Ray of `cpus` CPUs started here unless `address` names a cluster."""

    name = "ray"

    def __init__(self, cpus: int = 2, address: str | None = None) -> None:
        check_address(address)
        self.cpus = cpus
        self.address = address
        self._started = False

    def describe(self) -> str:
        if self.address is None:
            return f"ray, on this machine ({self.cpus} CPUs, 127.0.0.1)"
        return f"ray, cluster at {self.address}"

    def _connect(self) -> None:
        """Join the cluster, or start the local Ray, unless this process has a Ray already."""
        import ray

        if ray.is_initialized():
            return
        if self.address is None:
            start_local_ray(self.cpus)
        else:
            try:
                ray.init(address=self.address, logging_level=logging.WARNING, log_to_driver=False)
            except (ConnectionError, RuntimeError, ValueError) as error:
                raise ResusError(
                    f"cannot reach a Ray cluster at {self.address!r}: {_first_line(error)}"
                ) from None
        self._started = True

    def close(self) -> None:
        """Stop the Ray this executor started (or leave the cluster it joined)."""
        if self._started:
            import ray

            ray.shutdown()
            self._started = False

    def _prepare(self, resources: Resources, desc: str) -> None:
        """Join (or start) the Ray, and refuse units no node of it can run."""
        import ray

        self._connect()
        _check_feasible(resources, ray.cluster_resources(), desc)

    def _finished(
        self, function: Callable[[Item], Result], items: Sequence[Item], resources: Resources
    ) -> Iterator[tuple[int, Result]]:
        """One Ray task a unit; those still pending are cancelled when the map ends early."""
        import ray

        task = ray.remote(_run_unit).options(
            num_cpus=resources.cpus, num_gpus=resources.gpus, max_retries=RETRIES
        )
        pending = [task.remote(function, item, resources.cpus) for item in items]
        order = {ref: index for index, ref in enumerate(pending)}
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    yield order[ref], _result(ref)
        except BaseException:
            for ref in pending:
                ray.cancel(ref)
            raise


def _check_feasible(resources: Resources, cluster: dict[str, float], desc: str) -> None:
    """Refuse units the cluster can never run (Ray would wait for them forever)."""
    for name, wanted in (("CPU", resources.cpus), ("GPU", resources.gpus)):
        if wanted > cluster.get(name, 0.0):
            raise ResusError(
                f"{desc}: a unit needs {wanted:g} {name}s, the Ray cluster has "
                f"{cluster.get(name, 0.0):g}"
            )


def _result(ref: Any) -> Any:
    """A finished unit's result; its ResusError as raised in the worker, a worker lost more
    often than Ray retries as a WorkerLost."""
    import ray
    from ray.exceptions import RayError, RayTaskError

    try:
        return ray.get(ref)
    except RayTaskError as error:
        if isinstance(error.cause, ResusError):
            raise error.cause from None
        raise
    except RayError as error:
        raise WorkerLost(
            f"a unit's Ray worker or node was lost {RETRIES + 1} times ({type(error).__name__})"
        ) from None
