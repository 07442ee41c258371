"""The simulated side: one sweep per phantom subject, each scanned and imaged its own way."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.acquisition.patterns import LinearPattern
from resus.execution import Executor
from resus.experiments.sim2real.settings import Sim2RealSettings
from resus.experiments.vessel_targets import vessel_depth
from sim.ultrasound.scanner import RANDOM_RANGES, sweep_preset

if TYPE_CHECKING:
    from resus.acquisition.simulation import SimulatedSweepJob
    from sim.phantom import PhantomSpec
    from sim.robot.scene_config import SceneConfig
    from sim.ultrasound.scanner import ScannerPreset


def sweep_provenance(settings: Sim2RealSettings, subject: int, seed: int) -> dict:
    """What a subject's sweep of the experiment is made from
    (`resus.acquisition.simulation.sweep_provenance`): the data part of the keys of the models
    trained on it."""
    from resus.acquisition.simulation import sweep_provenance as simulated_provenance
    from sim.phantom import Phantom

    scene, spec = _subject_phantom(settings, subject, seed)
    preset = subject_preset(settings, spec, subject, seed)
    path = subject_sweep(settings, subject, seed).trajectory(Phantom(spec), scene.phantom_to_base)
    return simulated_provenance(scene, spec, preset, path)


def subject_job(
    settings: Sim2RealSettings, subject: int, seed: int, folder: Path
) -> SimulatedSweepJob:
    """A subject's sweep of the experiment, into `folder`: its own sweep (`subject_sweep`) and
    scanner preset (`subject_preset`), both drawn from (seed, subject)."""
    from resus.acquisition.simulation import SimulatedSweepJob, subject_sweep_path

    _, spec = _subject_phantom(settings, subject, seed)
    return SimulatedSweepJob(
        subject_sweep_path(folder, subject),
        subject_sweep(settings, subject, seed),
        phantom=settings.phantom,
        subject=subject,
        seed=seed,
        scanner=subject_preset(settings, spec, subject, seed),
    )


def _subject_phantom(
    settings: Sim2RealSettings, subject: int, seed: int
) -> tuple[SceneConfig, PhantomSpec]:
    """The default scene on the experiment's phantom and the subject's draw of it."""
    from resus.acquisition.simulation import phantom_spec, resolve_scene

    scene = resolve_scene("default", settings.phantom, subject)
    return scene, phantom_spec(scene, seed)


def simulate_subjects(
    folder: Path,
    settings: Sim2RealSettings,
    seed: int,
    executor: Executor,
    *,
    progress: bool = True,
) -> list[Path]:
    """One sweep per subject in `folder` (`subject_job`), each a unit on `executor`; a sweep
    made earlier with the same settings is kept (`simulate_sweeps`)."""
    from resus.acquisition.simulation import simulate_sweeps

    jobs = [subject_job(settings, k, seed, folder) for k in settings.subjects]
    simulate_sweeps(jobs, executor, progress=progress)
    return [job.out for job in jobs]


def off_vessel_subjects(settings: Sim2RealSettings, seed: int) -> frozenset[int]:
    """The subjects whose sweep lies off the vessels: `off_vessel_share` of them, rounded,
    drawn from the seed."""
    count = round(settings.off_vessel_share * len(settings.subjects))
    rng = np.random.default_rng([seed, 0x0FF5])
    return frozenset(int(k) for k in rng.choice(settings.subjects, count, replace=False))


def subject_sweep(settings: Sim2RealSettings, subject: int, seed: int) -> LinearPattern:
    """The nominal sweep moved sideways by up to `sweep_offset` (or, for the
    `off_vessel_subjects`, by `off_vessel_offset` to one side), tilted by up to
    `sweep_tilt_deg` and pressed with a force in `contact_forces`, drawn from (seed, subject):
    every subject is scanned its own way."""
    rng = np.random.default_rng([seed, subject, 0x5EE9])
    offset = rng.uniform(-settings.sweep_offset, settings.sweep_offset)
    tilt = rng.uniform(-settings.sweep_tilt_deg, settings.sweep_tilt_deg)
    force = rng.uniform(*settings.contact_forces)
    if subject in off_vessel_subjects(settings, seed):  # its own draw: the others' stay put
        aside = np.random.default_rng([seed, subject, 0x0FF5])
        offset = float(aside.choice((-1.0, 1.0)) * aside.uniform(*settings.off_vessel_offset))
    x, y = settings.sweep.start
    return dataclasses.replace(
        settings.sweep, start=(x + offset, y), tilt_deg=tilt, contact_force=float(force)
    )


def subject_preset(
    settings: Sim2RealSettings, spec: PhantomSpec, subject: int, seed: int
) -> ScannerPreset | None:
    """The scanner preset of a subject's sweep (`sweep_preset`), its displayed depth set, when
    `settings.target_depth_fraction` asks, so the vessels at the sweep's middle lie at a
    fraction of it drawn from (seed, subject)."""
    preset = sweep_preset(settings.scanner, seed, subject)
    if preset is None or settings.target_depth_fraction is None:
        return preset
    sweep = subject_sweep(settings, subject, seed)
    fraction = np.random.default_rng([seed, subject, 0xDE97]).uniform(
        *settings.target_depth_fraction
    )
    depth = vessel_depth(spec, float(sweep.middle[1])) / fraction
    return preset.at_depth(float(np.clip(depth, *RANDOM_RANGES["depth"])))
