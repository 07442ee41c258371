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
    from sim.phantom import PhantomSpec
    from sim.ultrasound.scanner import ScannerPreset


def sweep_provenance(settings: Sim2RealSettings, subject: int, seed: int) -> dict:
    """What a subject's sweep of the experiment must have been made from to be reused
    (`resus.acquisition.simulation.sweep_provenance`)."""
    return _subject_scan(settings, subject, seed)[0]


def _subject_scan(
    settings: Sim2RealSettings, subject: int, seed: int
) -> tuple[dict, ScannerPreset | None]:
    """A subject's sweep provenance (`sweep_provenance`) and the scanner preset that makes
    it, from one draw of the subject's phantom."""
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from resus.acquisition.simulation import sweep_provenance as simulated_provenance
    from sim.phantom import Phantom

    scene = resolve_scene("default", settings.phantom, subject)
    spec = phantom_spec(scene, seed)
    preset = subject_preset(settings, spec, subject, seed)
    path = subject_sweep(settings, subject, seed).trajectory(Phantom(spec), scene.phantom_to_base)
    return simulated_provenance(scene, spec, preset, path), preset


def simulate_subjects(
    folder: Path,
    settings: Sim2RealSettings,
    seed: int,
    executor: Executor,
    *,
    progress: bool = True,
) -> list[Path]:
    """One sweep per subject in `folder/subject_KK.h5`, each a unit on `executor`; a sweep
    already there from the same phantom, subject, seed, scanner and simulator
    (`sweep_provenance`) is kept."""
    from resus.sweep.io import SweepReader

    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"subject_{k:02d}.h5" for k in settings.subjects]
    work = []
    for subject, path in zip(settings.subjects, paths, strict=True):
        wanted, preset = _subject_scan(settings, subject, seed)
        if path.is_file():
            with SweepReader(path) as reader:
                made_from = {key: reader.provenance.get(key) for key in wanted}
            if made_from == wanted:
                continue
        work.append((path, settings, subject, seed, preset))
    executor.map(_simulate_sweep, work, "simulate", "sweep", progress=progress)
    return paths


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


def _simulate_sweep(
    job: tuple[Path, Sim2RealSettings, int, int, ScannerPreset | None],
) -> None:
    """One subject's sweep with its scanner preset (`_subject_scan`'s; top level so worker
    processes can run it)."""
    from resus.acquisition.simulation import resolve_scene, simulate_sweep
    from resus.execution import limit_numba_threads

    limit_numba_threads()
    path, settings, subject, seed, preset = job
    scene = resolve_scene("default", settings.phantom, subject)
    partial = path.with_suffix(".partial.h5")
    sweep = subject_sweep(settings, subject, seed)
    simulate_sweep(partial, scene, sweep, seed=seed, preset=preset, progress=False)
    partial.replace(path)  # a killed run leaves no half sweep under the final name
