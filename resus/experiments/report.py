"""Reports of the experiments: report.md (tables, tests, settings), results.json, PNG figures.

Every number in a report's tables is read from the results dictionary that is also written
as results.json (the results' `to_dict()`), rounded to three decimals, so the two always agree.
An IoU is printed as its mean and sample standard deviation over the training seeds
(`spread_text`), a comparison with its difference, seed spread, paired t-test and verdict
(`comparison_text`); the demo's report uses the same two.
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
        plot_training_curves(
            training.history, training.best_epoch, out / file_name, title, training.weight_average
        )
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


def spread_text(cell: dict, metric: str = "mean") -> str:
    """An IoU cell of results.json (or summary.json) as "mean ± std" over the seeds."""
    return f"{cell[metric]:.3f} ± {cell[f'{metric}_std']:.3f}"


def comparison_text(comparison: dict) -> str:
    """A comparison of results.json (or summary.json): difference, seed spread, paired
    t-test and, in bold, the verdict."""
    return (
        f"{comparison['a']} against {comparison['b']}, {comparison['metric']} IoU: difference "
        f"{comparison['difference']:+.3f}, seed spread {comparison['seed_spread']:.3f}, paired "
        f"t-test p = {_p(comparison['p_value'])} (n = {comparison['n']}): "
        f"**{comparison['verdict']}**"
    )


def seeds_text(seeds: Sequence[int]) -> str:
    """How the reports say which seeds a figure is over."""
    return f"{len(seeds)} training seeds ({', '.join(map(str, seeds))})"


SPREAD_RULE = (
    "A difference no larger than the seed spread (the larger of the two models' standard "
    "deviations over seeds) is reported as no difference."
)


def scanned_text(preset: dict) -> tuple[str, str]:
    """(the phantom, how it was imaged) of an experiment preset's `to_dict()`, for a report's
    opening sentence."""
    scans = preset["scans"]
    name, scanner = scans["phantom"], scans["scanner"]
    phantom = "the gel-block phantom" if name is None else f"the `{name}` phantom"
    imaging = "" if scanner is None else f", imaged through the `{scanner}` preset"
    if scans["centre_on_vessels"]:
        imaging += ", each sweep centred on its subject's artery and vein"
    return phantom, imaging


def write_phantom_report(out: Path, phantom: PhantomResults, figures: ReportFigures) -> Path:
    """report.md, results.json and figures of the phantom experiment."""
    out = Path(out)
    results = phantom.to_dict()
    titles = ("phantom scan B, trained on scan A", "trained on phantom scan A")
    curves = _write_json_and_figures(out, results, figures, titles)
    iou = results["iou"]
    tests = list(next(iter(iou.values())))
    header = [
        "| trained on scan A | " + " | ".join(f"tested on scan B {t}" for t in tests) + " |",
        "| --- |" + " --- |" * len(tests),
    ]
    scanned, imaging = scanned_text(results["preset"])
    lines = [
        f"# Phantom experiment (Table I analogue), preset {results['preset']['name']}",
        "",
        f"Two scans of {scanned} (nominal anatomy{imaging}): scan A trains, scan B tests "
        "(another start point and a tilt). Mean vessel IoU (artery and vein averaged): mean ± "
        f"sample standard deviation over {seeds_text(results['seeds'])}.",
        "",
        *header,
    ]
    for trained_on, row in iou.items():
        cells = [spread_text(row[t]) for t in tests]
        lines.append(f"| {trained_on} | " + " | ".join(cells) + " |")
    lines += ["", "Artery / vein IoU:", "", *header]
    for trained_on, row in iou.items():
        cells = [f"{spread_text(row[t], 'artery')} / {spread_text(row[t], 'vein')}" for t in tests]
        lines.append(f"| {trained_on} | " + " | ".join(cells) + " |")
    lines += ["", f"Each seed's mean IoU, seeds {', '.join(map(str, results['seeds']))}:", ""]
    for trained_on, row in iou.items():
        for test in tests:
            runs = ", ".join(f"{run['mean']:.3f}" for run in row[test]["runs"])
            lines.append(f"- trained on {trained_on}, tested on {test}: {runs}")
    lines += ["", "## Frames + reslices against frames only", "", SPREAD_RULE, ""]
    for test, comparisons in results["comparisons"].items():
        lines += [f"Tested on scan B {test}:", ""]
        lines += [f"- {comparison_text(comparison)}" for comparison in comparisons]
        lines.append("")
    scans = results["scans"]
    lines += [
        f"Scan A: {scans['A']['frames']} frames ({results['training_images']['frames']} for "
        f"training, {results['training_images']['validation_frames']} for validation), "
        f"{scans['A']['reslices']} reslices. Scan B: {scans['B']['frames']} frames, "
        f"{scans['B']['reslices']} reslices.",
        "",
    ]
    return _write_report(out, lines, curves, results)


def comparisons_against(loso: dict, reference: str, metric: str) -> dict[str, dict]:
    """Every other regime's comparison with `reference` on `metric`, by that regime (its
    p-value and verdict read the same whichever way round it was made)."""
    found = {}
    for comparison in loso["comparisons"]:
        if comparison["metric"] == metric and reference in (comparison["a"], comparison["b"]):
            other = comparison["b"] if comparison["a"] == reference else comparison["a"]
            found[other] = comparison
    return found


def subjects_table(results: dict) -> list[str]:
    """Markdown: mean IoU per held-out subject and regime (mean ± std over seeds), the
    average, and each regime against resus (paired t-test p, verdict)."""
    loso = results["loso"]
    run = {r: e for r, e in loso["regimes"].items() if e["status"] == "run"}
    regimes = list(run)
    lines = ["| held-out subject | " + " | ".join(regimes) + " |", "| --- |" + " --- |" * len(run)]
    for subject in loso["subjects"]:
        cells = [spread_text(run[r]["iou"][subject]) for r in regimes]
        lines.append(f"| {subject} | " + " | ".join(cells) + " |")
    average = [f"**{spread_text(run[r]['mean_over_subjects'])}**" for r in regimes]
    lines.append("| **average** | " + " | ".join(average) + " |")
    if "resus" in run:
        against = comparisons_against(loso, "resus", "mean")
        p_values = [_p(against[r]["p_value"]) if r != "resus" else "" for r in regimes]
        verdicts = [against[r]["verdict"] if r != "resus" else "" for r in regimes]
        lines.append("| p vs resus | " + " | ".join(p_values) + " |")
        lines.append("| verdict vs resus | " + " | ".join(verdicts) + " |")
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
    scanned, imaging = scanned_text(results["preset"])
    lines = [
        f"# Subjects experiment (Table II analogue), preset {results['preset']['name']}",
        "",
        f"Leave-one-subject-out over simulated subjects (variants of {scanned}: anatomy, "
        f"echogenicity and noise differ{imaging}). Each cell: vessel IoU (artery and vein "
        "averaged) on the held-out subject's frames, pooled over its frames, of a model "
        "trained on the other subjects: mean ± sample standard deviation over "
        f"{seeds_text(results['seeds'])}; the average is taken over subjects seed by seed. "
        "p: two-sided paired t-test against resus, one pair per held-out subject and seed. "
        + SPREAD_RULE,
        "",
        *subjects_table(results),
        "",
        "Artery / vein IoU, averaged over subjects:",
        "",
    ]
    classes = ("artery", "vein")
    # the p columns need resus among the regimes that ran
    against = {c: comparisons_against(loso, "resus", c) for c in classes} if "resus" in run else {}
    columns = ["regime", *classes, *(f"{c} p vs resus" for c in against)]
    lines += ["| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    for regime, entry in run.items():
        mean = entry["mean_over_subjects"]
        cells = [regime, *(spread_text(mean, c) for c in classes)]
        cells += [_p(by[regime]["p_value"]) if regime != "resus" else "" for by in against.values()]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "## Every pair of regimes", ""]
    lines += [f"- {comparison_text(comparison)}" for comparison in loso["comparisons"]]
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
        f"The `us` regime scores {check['us_within_subject_iou']:.3f} mean IoU (mean over "
        "seeds) on held-out frames of its training subjects (the validation tail of each "
        f"sweep) and {check['us_held_out_subject_iou']:.3f} on the held-out subject: a gap of "
        f"{check['gap']:+.3f}; its held-out IoU varies by "
        f"{check['held_out_iou_std_over_subjects']:.3f} "
        f"(standard deviation) over subjects. Generalising across subjects is a real problem "
        f"(gap or spread above {check['threshold']}): **{verdict}**.",
    ]
