"""Labelled image sets from files: sweeps (`resus.sweep/1`) and reslices (`resus.reslices/1`).

Thin adapters from the two file readers to `LabelledImages`; a directory stands for the
HDF5 files in it. Every set needs its subject id, since evaluation splits on it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.segmentation.data import LabelledImages
from sim.labels import LABEL_NAMES

HDF5_SUFFIXES = (".h5", ".hdf5")


def expand_paths(paths: Sequence[Path], kind: str) -> list[Path]:
    """Files named in `paths`, each directory replaced by its sorted HDF5 files; `kind` names
    what the files hold (e.g. "sweep") in the errors."""
    files: list[Path] = []
    for path in map(Path, paths):
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.suffix in HDF5_SUFFIXES)
            if not found:
                raise ResusError(f"no .h5 {kind} files in directory", path)
            files += found
        elif path.is_file():
            files.append(path)
        else:
            raise ResusError(f"no such {kind} file or directory", path)
    return files


def check_label_names(names: Sequence[str], path: Path) -> None:
    """Labels must mean what the network learns: 0 background, 1 artery, 2 vein."""
    if tuple(names)[: len(LABEL_NAMES)] != LABEL_NAMES:
        raise ResusError(f"label names {tuple(names)} do not start with {LABEL_NAMES}", path)


def load_sweep_frames(paths: Sequence[Path]) -> list[LabelledImages]:
    """One labelled set per sweep file (or per sweep file in a directory)."""
    from resus.sweep.io import read_sweep

    sets = []
    for path in expand_paths(paths, "sweep"):
        sweep = read_sweep(path)
        if sweep.labels is None:
            raise ResusError("sweep has no labels: training needs labelled frames", path)
        if not sweep.subject:
            raise ResusError("sweep has no subject id: evaluation splits by subject", path)
        check_label_names(sweep.label_names, path)
        sets.append(
            LabelledImages(
                np.asarray(sweep.frames), np.asarray(sweep.labels), sweep.subject, str(path)
            )
        )
    return sets


def load_reslice_sets(paths: Sequence[Path]) -> list[LabelledImages]:
    """One labelled set per reslice dataset file (or per file in a directory)."""
    from resus.reslicing.dataset import ResliceDataset

    sets = []
    for path in expand_paths(paths, "reslice"):
        with ResliceDataset(path) as dataset:
            subject = str(dataset.attrs.get("subject", ""))
            if not subject:
                raise ResusError("reslices have no subject id: evaluation splits by subject", path)
            check_label_names(dataset.label_names, path)
            sets.append(LabelledImages(dataset.images[:], dataset.labels[:], subject, str(path)))
    return sets
