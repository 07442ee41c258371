"""Simulated acquisition end to end: scene, robot, probe, trajectory -> a Sweep file.

`SimulatedSweepJob` names one sweep in plain values (so a worker process or a Ray node can
make it); `simulate_sweeps` makes many, each a resumable unit, and `simulate_subject_sweeps`
one per phantom subject.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.patterns import SweepPattern
from resus.acquisition.scanner import Scanner, ScannerSettings, ScanResult
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError, simulator_errors
from resus.sweep.model import FrameSink, check_provenance
from sim.fingerprint import simulator_fingerprint
from sim.phantom import Phantom, PhantomSpec, phantom_digest
from sim.robot.scene import load_scene_phantom
from sim.robot.scene_config import SceneConfig, load_scene_config, scene_path
from sim.ultrasound.scanner import ScannerPreset, sweep_preset

if TYPE_CHECKING:
    from resus.execution import Executor, UnitRecord

SUBJECT_ID = re.compile(r"^(?P<phantom>[^/]+)/(?P<subject>nominal|\d+)$")
DONE_FOLDER = ".done"
"""Beside the sweeps `simulate_sweeps` makes: one record per finished sweep."""


def resolve_scene(scene: str | Path, phantom: str | None, subject: int | None) -> SceneConfig:
    """A scene by name (`assets/scenes/NAME.yaml`) or path, with phantom and subject set."""
    changes: dict[str, Any] = {"subject": subject} if subject is not None else {}
    if phantom is not None:
        changes["phantom"] = phantom
    with simulator_errors():
        return dataclasses.replace(load_scene_config(scene_path(scene)), **changes)


def world_key(scene: SceneConfig, preset: ScannerPreset | None) -> dict[str, Any]:
    """The simulated world and scanner a sweep is made with, as JSON values a cache compares:
    the scene's content, not its file's name (a scene edited in place is another scene), the
    digest of its phantom spec's files (`scene_phantom_digest`), every knob of the scanner
    preset (None: the probe's own settings) and the simulator's fingerprint."""
    return {
        "scene": scene.to_dict(),
        "phantom_digest": scene_phantom_digest(scene),
        "scanner": None if preset is None else preset.to_dict(),
        "simulator": simulator_fingerprint(),
    }


def scene_phantom_digest(scene: SceneConfig) -> str:
    """`phantom_digest` of the scene's phantom: an edited spec, or one it extends, is another
    phantom."""
    with simulator_errors(f"phantom {scene.phantom!r}"):
        return phantom_digest(scene.phantom)


def sweep_provenance(
    scene: SceneConfig,
    spec: PhantomSpec,
    preset: ScannerPreset | None,
    trajectory: Trajectory,
    *,
    rigid: bool = False,
) -> dict:
    """What a simulated sweep is made from, as JSON values recorded with it and compared by
    the caches of simulated data: the phantom (and the digest of its spec's files: one edited
    in place is another phantom), subject, seed, scanner preset (its name and every knob: a
    preset file edited in place keeps its name), the sweep pattern and force (where and how
    it was scanned), whether the tissue deformed, and the simulator (its fingerprint). In the
    form a sweep stores it (`check_provenance`), so a cache compares it with a file's as is."""
    return check_provenance(
        {
            "phantom": scene.phantom,
            "phantom_digest": scene_phantom_digest(scene),
            "subject": scene.subject,
            "seed": spec.seed,
            "scanner": None if preset is None else preset.name,
            "scanner_knobs": None if preset is None else preset.to_dict(),
            "pattern": trajectory.pattern,
            "contact_force": trajectory.contact_force,
            "deformation": spec.mechanics is not None and not rigid,
            "simulator": simulator_fingerprint(),
        }
    )


def phantom_spec(scene: SceneConfig, seed: int | None = None) -> PhantomSpec:
    """The scene's phantom, with its seed replaced if given, then its subject's variant."""
    with simulator_errors(f"phantom {scene.phantom!r}"):
        return load_scene_phantom(scene, seed)


def simulate_sweep(
    out: str | Path,
    scene: SceneConfig,
    trajectory: Trajectory | SweepPattern,
    *,
    seed: int | None = None,
    probe: SimulatedProbeConfig | None = None,
    preset: ScannerPreset | None = None,
    progress: bool = True,
    listeners: Sequence[FrameSink] = (),
    rigid: bool = False,
) -> ScanResult:
    """Scan the scene's phantom with the simulated UR3e along `trajectory` (or a pattern made
    over the phantom) and write a labelled Sweep to `out`; `listeners` (the scanner's) get
    every frame as it is recorded, e.g. an OpenIGTLink server streaming the scan live.
    `preset` sets the frequency, depth and imaging knobs of a scanner preset on top of
    `probe`'s array width, image size and frame rate. A phantom with mechanics deforms under
    the measured contact force unless `rigid`."""
    spec = phantom_spec(scene, seed)
    phantom = Phantom(spec)
    if isinstance(trajectory, SweepPattern):
        trajectory = trajectory.trajectory(phantom, scene.phantom_to_base)
    robot = SimulatedRobot(scene)
    probe_config = imaging_probe(
        probe or SimulatedProbeConfig(frame_rate=trajectory.frame_rate), preset, rigid
    )
    probe_source = SimulatedProbe(robot, probe_config, phantom)
    scanner = Scanner(
        robot, probe_source, settings=ScannerSettings(progress=progress), listeners=listeners
    )
    provenance = {
        **sweep_provenance(scene, spec, preset, trajectory, rigid=probe_config.rigid),
        "dynamic_range_db": probe_config.settings.dynamic_range_db,
    }
    return scanner.run(
        trajectory, out, source="sim", subject=subject_id(scene), provenance=provenance
    )


def imaging_probe(
    probe: SimulatedProbeConfig, preset: ScannerPreset | None, rigid: bool = False
) -> SimulatedProbeConfig:
    """The probe a sweep is imaged with: `preset`'s frequency, depth and imaging knobs on top
    of `probe`'s array width, image size and frame rate, and the rigid world if asked."""
    if rigid:
        probe = dataclasses.replace(probe, rigid=True)
    if preset is None:
        return probe
    return dataclasses.replace(
        probe, probe=preset.probe(probe.probe), settings=preset.settings(probe.settings)
    )


def simulated_truth(scene: SceneConfig, provenance: Mapping[str, object]) -> PhantomSpec:
    """The phantom a simulated Sweep was recorded from, as its `provenance` says (its seed
    included), for scoring against `scene`; a ResusError when the scene names another
    phantom or subject than the sweep was made from, or a spec whose files changed since
    (`phantom_digest`), since the scores would compare different anatomy."""
    made_from = (provenance.get("phantom"), provenance.get("subject"))
    if "phantom" in provenance and made_from != (scene.phantom, scene.subject):
        raise ResusError(
            f"the sweep was simulated from phantom {made_from[0]!r} subject {made_from[1]} "
            f"(its provenance), not {scene.phantom!r} subject {scene.subject}: scores would "
            "compare different anatomy"
        )
    recorded = provenance.get("phantom_digest")
    if recorded is not None and recorded != scene_phantom_digest(scene):
        raise ResusError(
            f"phantom {scene.phantom!r} is not the spec the sweep was simulated from (its "
            f"files changed since: digest {recorded} in the provenance): scores would compare "
            "different anatomy"
        )
    seed = provenance.get("seed")
    return phantom_spec(scene, seed if isinstance(seed, int) else None)


def subject_id(scene: SceneConfig) -> str:
    """The subject a simulated Sweep records: "PHANTOM/K", or "PHANTOM/nominal"."""
    variant = "nominal" if scene.subject is None else str(scene.subject)
    return f"{scene.phantom}/{variant}"


def parse_subject_id(subject: str) -> tuple[str | None, int | None]:
    """Phantom name and subject index of a `subject_id` ("default/3" -> ("default", 3);
    "default/nominal" -> ("default", None)), or (None, None) for any other subject text."""
    match = SUBJECT_ID.match(subject)
    if match is None:
        return None, None
    index = match["subject"]
    return match["phantom"], None if index == "nominal" else int(index)


@dataclass(frozen=True)
class SimulatedSweepJob:
    """One simulated sweep to make, in plain values (`simulate_sweep`'s arguments by name)."""

    out: Path
    """The Sweep file to write."""
    plan: SweepPattern | Path
    """A sweep pattern (made over the phantom) or a trajectory YAML file (read where the job
    runs)."""
    scene: str | Path = "default"
    """A scene name (`assets/scenes`) or file."""
    phantom: str | None = None
    """A phantom instead of the scene's own (`resolve_scene`)."""
    subject: int | None = None
    seed: int | None = None
    """The phantom's seed: its anatomy's draw and its speckle (None: the spec's)."""
    scanner: str | ScannerPreset | None = None
    """A scanner preset, or one named (`sim.ultrasound.scanner.sweep_preset`: a name, a file,
    "random-N", or "random", drawn for the seed and subject); None: the simulator's own
    settings."""
    rigid: bool = False
    """Image the rigid world: no deformation under the probe, no pulsation."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "out", Path(self.out))
        if isinstance(self.plan, str):
            object.__setattr__(self, "plan", Path(self.plan))
        elif not isinstance(self.plan, SweepPattern | Path):
            raise ResusError(
                "SimulatedSweepJob.plan must be a sweep pattern or a trajectory file, got "
                f"{self.plan!r}"
            )

    def scene_config(self) -> SceneConfig:
        """The scene with the job's phantom and subject."""
        return resolve_scene(self.scene, self.phantom, self.subject)

    def scanner_preset(self) -> ScannerPreset | None:
        """The job's scanner preset (None: the simulator's own settings)."""
        if isinstance(self.scanner, ScannerPreset):
            return self.scanner
        with simulator_errors("SimulatedSweepJob.scanner"):
            return sweep_preset(self.scanner, self.seed, self.subject)

    def image_to_probe(self) -> np.ndarray:
        """The calibration of the sweep's frames (`imaging_probe`: the scanner preset sets
        their depth), known before the first frame, e.g. for a live OpenIGTLink stream."""
        probe = imaging_probe(SimulatedProbeConfig(), self.scanner_preset(), self.rigid)
        return probe.probe.image_to_probe()

    def key(self) -> dict[str, Any]:
        """Everything the sweep depends on, as a cache compares it: the world and scanner
        (`world_key`), the plan (a file's text with its path: a file edited in place makes a
        new sweep), the seed and whether the world is rigid."""
        plan = self.plan
        return {
            **world_key(self.scene_config(), self.scanner_preset()),
            "trajectory": (
                {"path": str(plan), "text": plan.read_text()}
                if isinstance(plan, Path)
                else dataclasses.asdict(plan)
            ),
            "seed": self.seed,
            "rigid": self.rigid,
        }

    def record(self) -> UnitRecord:
        """Where the sweep is recorded as made, with its `key`: under `DONE_FOLDER` beside it
        (`simulate_sweeps`)."""
        from resus.execution import UnitRecord

        record = self.out.parent / DONE_FOLDER / f"{self.out.stem}.json"
        return UnitRecord(record, self.key(), (self.out,))

    def run(self, *, progress: bool = True, listeners: Sequence[FrameSink] = ()) -> ScanResult:
        """Make the sweep (`simulate_sweep`)."""
        plan = Trajectory.from_yaml(self.plan) if isinstance(self.plan, Path) else self.plan
        return simulate_sweep(
            self.out,
            self.scene_config(),
            plan,
            seed=self.seed,
            preset=self.scanner_preset(),
            progress=progress,
            listeners=listeners,
            rigid=self.rigid,
        )


def subject_sweep_path(folder: Path, subject: int) -> Path:
    """Where a folder of subjects' sweeps keeps subject `subject`'s: `folder/subject_KK.h5`."""
    return folder / f"subject_{subject:02d}.h5"


def simulate_subject_sweeps(
    job: SimulatedSweepJob, subjects: Sequence[int], folder: Path, executor: Executor
) -> tuple[list[Path], list[Path]]:
    """`job` once per subject into `folder` (`subject_sweep_path`), by `simulate_sweeps`:
    every sweep's path, and those kept from an earlier run."""
    jobs = [
        dataclasses.replace(job, subject=k, out=subject_sweep_path(folder, k)) for k in subjects
    ]
    return [job.out for job in jobs], simulate_sweeps(jobs, executor)


def simulate_sweeps(
    jobs: Sequence[SimulatedSweepJob], executor: Executor, *, progress: bool = True
) -> list[Path]:
    """Each job a unit on `executor`, recorded when it finishes beside its sweep (under
    `DONE_FOLDER`) with its `key`, so a rerun makes only the sweeps that are missing or were
    made otherwise: the sweeps kept from an earlier run. A sweep killed half made has no
    record, so the next run makes it again."""
    from resus.execution import run_pending

    kept = [job.out for job in jobs if job.record().done()]
    for folder in {job.out.parent for job in jobs}:
        folder.mkdir(parents=True, exist_ok=True)
    run_pending(executor, _make_sweep, jobs, "simulate", "sweep", progress=progress)
    return kept


def _make_sweep(job: SimulatedSweepJob) -> tuple[str, int]:
    """One sweep, quietly (top level so worker processes can run it), with numba's threads
    cut to the unit's cores so units side by side do not oversubscribe them."""
    from resus.execution import limit_numba_threads

    limit_numba_threads()
    result = job.run(progress=False)
    return str(result.path), result.frames
