"""Reports of the experiments: report.md (tables, tests, settings), results.json, PNG figures.

Every number in a report's tables is read from the results dictionary that is also written
as results.json (the results' `to_dict()`), rounded to three decimals, so the two always agree.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.experiments.results import PhantomResults, SubjectsResults
from resus.segmentation.curves import plot_training_curves

if TYPE_CHECKING:
    from resus.experiments.tables import Example
    from resus.segmentation.train import TrainingSummary

PREDICTIONS_PNG = "predictions.png"


@dataclass(frozen=True)
class ReportFigures:
    """What a report's pictures show: example images with each model's prediction, and the
    training history of each model (by name)."""

    examples: Sequence[Example]
    histories: Mapping[str, TrainingSummary]


def save_prediction_figure(path: Path, examples: Sequence[Example], title: str) -> Path:
    """One row per example: image, truth, then each prediction (artery red, vein blue)."""
    from matplotlib.figure import Figure

    from resus.reslicing.sheet import overlay_labels
    from resus.segmentation.metrics import vessel_iou

    names = list(examples[0].predictions)
    columns = 2 + len(names)
    figure = Figure(figsize=(2.6 * columns, 2.9 * len(examples)))
    panels = figure.subplots(len(examples), columns, squeeze=False)
    for row, example in zip(panels, examples, strict=True):
        pictures = [
            ("image", example.image),
            ("truth", overlay_labels(example.image, example.truth)),
        ]
        for name in names:
            predicted = example.predictions[name]
            iou = vessel_iou(predicted, example.truth).mean
            pictures.append((f"{name}\nIoU {iou:.2f}", overlay_labels(example.image, predicted)))
        for panel, (caption, picture) in zip(row, pictures, strict=True):
            panel.imshow(picture, cmap="gray", vmin=0, vmax=255)
            panel.set_title(caption, fontsize=9)
            panel.axis("off")
        row[0].set_title(f"{example.title}\nimage", fontsize=9)
    figure.suptitle(f"{title} (artery red, vein blue)")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=80)
    return path


def save_curves(out: Path, histories: Mapping[str, TrainingSummary], subject: str) -> list[str]:
    """Training curves of each named run as `curves_NAME.png`; the file names."""
    names = []
    for name, training in histories.items():
        file_name = "curves_" + name.replace(" + ", "_").replace(" ", "_") + ".png"
        title = f"{name}, {subject}"
        plot_training_curves(training.history, training.best_epoch, out / file_name, title)
        names.append(file_name)
    return names


def _write_json_and_figures(
    out: Path, results: dict, figures: ReportFigures, titles: tuple[str, str]
) -> list[str]:
    """results.json, predictions.png and the training curves, titled (predictions, curves);
    the curves' file names."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    save_prediction_figure(out / PREDICTIONS_PNG, figures.examples, titles[0])
    return save_curves(out, figures.histories, titles[1])


def _settings_section(results: dict) -> list[str]:
    seconds = results["seconds"]
    return [
        "## Settings",
        "",
        f"- command: `{results['command']}`",
        f"- device: {results['device']}, torch threads: {results['torch_threads']}",
        f"- executor: {results['executor']}",
        f"- data (sweeps, volumes, reslices; cached): `{results['data_folder']}`",
        f"- time: data {seconds['data']} s, training and scoring {seconds['training']} s",
        "- preset (data and training), as run:",
        "",
        "```json",
        json.dumps(results["preset"], indent=1),
        "```",
    ]


def _write_report(out: Path, lines: list[str], curves: list[str], results: dict) -> Path:
    """report.md: `lines`, then the figures and the settings."""
    figures = ["## Figures", "", *_figures([PREDICTIONS_PNG, *curves]), ""]
    path = out / "report.md"
    path.write_text("\n".join([*lines, *figures, *_settings_section(results)]) + "\n")
    return path


def _figures(names: Sequence[str]) -> list[str]:
    return [f"![{name}]({name})" for name in names]


def write_phantom_report(out: Path, phantom: PhantomResults, figures: ReportFigures) -> Path:
    """report.md, results.json and figures of the phantom experiment."""
    out = Path(out)
    results = phantom.to_dict()
    titles = ("phantom scan B, trained on scan A", "trained on phantom scan A")
    curves = _write_json_and_figures(out, results, figures, titles)
    iou = results["iou"]
    tests = list(next(iter(iou.values())))
    seeds = results["seeds"]
    header = [
        "| trained on scan A | " + " | ".join(f"tested on scan B {t}" for t in tests) + " |",
        "| --- |" + " --- |" * len(tests),
    ]
    lines = [
        f"# Phantom experiment (Table I analogue), preset {results['preset']['name']}",
        "",
        "Two scans of the gel-block phantom (nominal anatomy): scan A trains, scan B tests "
        "(another start point and a tilt). Mean vessel IoU (artery and vein averaged), mean "
        f"over {len(seeds)} training seeds {seeds} (standard deviation in brackets).",
        "",
        *header,
    ]
    for trained_on, row in iou.items():
        cells = [f"{row[t]['mean']:.3f} ({row[t]['mean_std']:.3f})" for t in tests]
        lines.append(f"| {trained_on} | " + " | ".join(cells) + " |")
    lines += ["", "Artery / vein IoU:", "", *header]
    for trained_on, row in iou.items():
        cells = [f"{row[t]['artery']:.3f} / {row[t]['vein']:.3f}" for t in tests]
        lines.append(f"| {trained_on} | " + " | ".join(cells) + " |")
    scans = results["scans"]
    lines += [
        "",
        f"Scan A: {scans['A']['frames']} frames ({results['training_images']['frames']} for "
        f"training, {results['training_images']['validation_frames']} for validation), "
        f"{scans['A']['reslices']} reslices. Scan B: {scans['B']['frames']} frames, "
        f"{scans['B']['reslices']} reslices.",
        "",
    ]
    return _write_report(out, lines, curves, results)


def p_values_against(loso: dict, reference: str, metric: str) -> dict[str, float | None]:
    """Paired t-test p-value of every other regime against `reference` on `metric`."""
    found = {}
    for test in loso["paired_t_tests"]:
        if test["metric"] == metric and reference in (test["a"], test["b"]):
            other = test["b"] if test["a"] == reference else test["a"]
            found[other] = test["p_value"]
    return found


def subjects_table(results: dict) -> list[str]:
    """Markdown: mean IoU per held-out subject and regime, the average, p-values vs resus."""
    loso = results["loso"]
    run = {r: e for r, e in loso["regimes"].items() if e["status"] == "run"}
    regimes = list(run)
    lines = ["| held-out subject | " + " | ".join(regimes) + " |", "| --- |" + " --- |" * len(run)]
    for subject in loso["subjects"]:
        cells = [f"{run[r]['iou'][subject]['mean']:.3f}" for r in regimes]
        lines.append(f"| {subject} | " + " | ".join(cells) + " |")
    average = [f"**{run[r]['mean_over_subjects']['mean']:.3f}**" for r in regimes]
    lines.append("| **average** | " + " | ".join(average) + " |")
    if "resus" in run:
        p_values = p_values_against(loso, "resus", "mean")
        cells = [_p(p_values.get(r)) if r != "resus" else "" for r in regimes]
        lines.append("| p vs resus | " + " | ".join(cells) + " |")
    return lines


def _p(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3g}"


def write_subjects_report(out: Path, subjects: SubjectsResults, figures: ReportFigures) -> Path:
    """report.md, results.json and figures of the leave-one-subject-out experiment."""
    out = Path(out)
    results = subjects.to_dict()
    loso = results["loso"]
    first = loso["subjects"][0]
    titles = (f"trained without subject {first}", f"held-out subject {first}")
    curves = _write_json_and_figures(out, results, figures, titles)
    run = {r: e for r, e in loso["regimes"].items() if e["status"] == "run"}
    lines = [
        f"# Subjects experiment (Table II analogue), preset {results['preset']['name']}",
        "",
        "Leave-one-subject-out over simulated subjects (variants of the gel-block phantom: "
        "anatomy, echogenicity and noise differ). Each cell: vessel IoU (artery and vein "
        "averaged) on the held-out subject's frames, pooled over its frames, of a model "
        f"trained on the other subjects (seed {results['seed']}). p: two-sided paired t-test "
        "across subjects against resus.",
        "",
        *subjects_table(results),
        "",
        "Artery / vein IoU, averaged over subjects:",
        "",
        "| regime | artery | vein | artery p vs resus | vein p vs resus |",
        "| --- | --- | --- | --- | --- |",
    ]
    artery_p = p_values_against(loso, "resus", "artery")
    vein_p = p_values_against(loso, "resus", "vein")
    for regime, entry in run.items():
        mean = entry["mean_over_subjects"]
        lines.append(
            f"| {regime} | {mean['artery']:.3f} | {mean['vein']:.3f} | "
            f"{_p(artery_p.get(regime)) if regime != 'resus' else ''} | "
            f"{_p(vein_p.get(regime)) if regime != 'resus' else ''} |"
        )
    for regime, entry in loso["regimes"].items():
        if entry["status"] != "run":
            lines.append(f"\n{regime}: not run ({entry['reason']})")
    counts = results["images_per_subject"]
    frames = sorted({c["frames"] for c in counts.values()})
    reslices = sorted({c["reslices"] for c in counts.values()})
    lines += [
        "",
        f"Images per subject: {', '.join(map(str, frames))} frames, "
        f"{', '.join(map(str, reslices))} reslices. Training images per fold: "
        + ", ".join(
            f"{r} {int(np.mean(list(n.values())))}" for r, n in results["training_images"].items()
        )
        + ".",
        "",
        "## Do the subjects differ enough?",
        "",
        *_generalisation_lines(results["generalisation"]),
        "",
    ]
    return _write_report(out, lines, curves, results)


def _generalisation_lines(check: dict) -> list[str]:
    if "gap" not in check:
        return [check["verdict"]]
    verdict = "yes" if check["subjects_differ_enough"] else "no"
    return [
        f"The `us` regime scores {check['us_within_subject_iou']:.3f} mean IoU on held-out "
        f"frames of its training subjects (the validation tail of each sweep) and "
        f"{check['us_held_out_subject_iou']:.3f} on the held-out subject: a gap of "
        f"{check['gap']:+.3f}; its held-out IoU varies by "
        f"{check['held_out_iou_std_over_subjects']:.3f} "
        f"(standard deviation) over subjects. Generalising across subjects is a real problem "
        f"(gap or spread above {check['threshold']}): **{verdict}**.",
    ]
