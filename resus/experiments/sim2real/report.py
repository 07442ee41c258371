"""The sim-to-real report: report.md, results.json, the few-label curve and example PNGs.

Every number of report.md is read from the dictionary written as results.json, so the two
always agree.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.errors import ResusError
from resus.experiments.realism import REAL_CREDIT, RealismComparison

if TYPE_CHECKING:
    from resus.experiments.sim2real.experiment import Sim2RealResult
    from resus.segmentation.folders import FolderImages

RESULTS_JSON, REPORT_MD = "results.json", "report.md"
CURVE_PNG, EXAMPLES_PNG = "few_label_curve.png", "examples.png"
EXAMPLE_IMAGES = 4
"""Real test images the example figure shows."""
SIM_ONLY_GOAL = 0.5
"""Issue #13's goal: vessel IoU of the simulation-only model on real images."""
LABELS_WITH_PRETRAINING, LABELS_WITHOUT = 25, 100
"""Issue #13's question: do 25 real labels with simulation pretraining reach what 100 reach
without it?"""


def credit(real_folder: str) -> str:
    """Who to credit for the real images shown."""
    if Path(real_folder).name == "usgra_seg":
        return REAL_CREDIT
    return f"real: {real_folder} (credit its authors as its licence asks)"


def write_sim2real_report(
    out: Path,
    result: Sim2RealResult,
    realism: RealismComparison,
    test_images: FolderImages,
    examples: Mapping[tuple[str, int], Sequence[np.ndarray]],
) -> None:
    """results.json, report.md, few_label_curve.png and examples.png into `out`."""
    results = result.to_dict()
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / RESULTS_JSON).write_text(json.dumps(results, indent=2) + "\n")
        save_curve_png(out / CURVE_PNG, results)
        save_examples_png(out / EXAMPLES_PNG, test_images, examples, results["real_folder"])
        lines = report_lines(results, realism)
        (out / REPORT_MD).write_text("\n".join(lines) + "\n")
    except OSError as error:
        raise ResusError(
            f"cannot write the report there ({error.strerror or error})", out
        ) from None


def _spread(entry: Mapping[str, float] | None) -> str:
    if entry is None:
        return "-"
    if entry["runs"] == 1:
        return f"{entry['mean']:.3f}"
    return f"{entry['mean']:.3f} ± {entry['std']:.3f}"


def pretraining_verdict(summary: Mapping[str, Mapping[str, Mapping[str, float]]]) -> str:
    """Whether 25 labels with pretraining reach 100 without, in one sentence (the k values
    the run has; the largest k stands in for 100 when it is smaller)."""
    pretrained, scratch = summary["simulation"], summary["scratch"]
    few = str(LABELS_WITH_PRETRAINING) if str(LABELS_WITH_PRETRAINING) in pretrained else None
    many = max(scratch, key=int) if scratch else None
    if few is None or many is None:
        return "The run has no k = 25 with pretraining or no k > 0 from scratch to compare."
    a, b = pretrained[few], scratch[many]
    margin = a["mean"] - b["mean"]
    spread = max(a["std"], b["std"])
    if abs(margin) <= spread:
        outcome = "no different from (the gap is within the spread over splits)"
    else:
        outcome = "above" if margin > 0 else "below"
    return (
        f"{few} real labels with simulation pretraining give IoU {_spread(a)}, {outcome} "
        f"{many} labels from scratch ({_spread(b)})."
    )


def _rehearsal_clause(frames: int) -> str:
    """How a fine-tuning from simulation spends its budget, when it rehearses."""
    if not frames:
        return ""
    return (
        f"; one from simulation rehearses: {frames} simulated frames of its own training "
        "sweeps join every epoch, in fewer epochs for the same total"
    )


def _ensemble_lines(members: Sequence[Mapping]) -> list[str]:
    """What an ensemble's members score alone (nothing for a single model)."""
    if not members:
        return []
    scores = [member["pooled"]["vessel"]["iou"] for member in members]
    pairs = zip(members, scores, strict=True)
    alone = ", ".join(f"seed {member['seed']}: {iou:.3f}" for member, iou in pairs)
    return [
        f"The model is an ensemble of {len(members)} (their mean class probabilities), each "
        f"trained on simulated subjects of its own; alone, their pooled IoU is {alone} (mean "
        f"{np.mean(scores):.3f}). The few-label curve starts from the first.",
        "",
    ]


def report_lines(results: Mapping, realism: RealismComparison) -> list[str]:
    """report.md, line by line."""
    settings, sim_only = results["settings"], results["sim_only"]
    vessel = sim_only["pooled"]["vessel"]
    mean = sim_only["per_image_mean"]["vessel"]
    summary = results["curve_summary"]
    goal = "reaches" if vessel["iou"] >= SIM_ONLY_GOAL else "does not reach"
    counts = settings["label_counts"]
    test_sizes = sorted({len(split["test"]) for split in results["splits"]})
    lines = [
        "# Sim-to-real",
        "",
        *([f"Command: `{results['command']}`", ""] if results["command"] else []),
        f"Real images: `{results['real_folder']}` ({sim_only['real_images']} images); "
        f"{credit(results['real_folder'])}.",
        "",
        "## Trained on simulation only",
        "",
        f"{len(results['sweeps'])} simulated subjects of the `{settings['phantom']}` phantom, "
        f"scanner `{settings['scanner']}`, training preset `{settings['training']}`, regime "
        f"`{settings['regime']}`, seed {results['seed']}. No real image entered training.",
        "",
        "| vessel (artery or vein) | IoU | Dice |",
        "| --- | ---: | ---: |",
        f"| pooled over every real image | {vessel['iou']:.3f} | {vessel['dice']:.3f} |",
        f"| mean over images | {mean['iou']:.3f} | {mean['dice']:.3f} |",
        "",
        *_ensemble_lines(sim_only["members"]),
        f"The simulation-only model {goal} the goal IoU {SIM_ONLY_GOAL} on these images. "
        "Overlays: `sim_only/evaluation/overlays/`.",
        "",
        "## Few real labels",
        "",
        f"{len(results['splits'])} random splits; each keeps {counts[-1]} images for "
        f"fine-tuning and tests on the other {', '.join(map(str, test_sizes))}. Each "
        f"fine-tuning sees {settings['fine_tune_epochs'] * settings['fine_tune_epoch_images']} "
        f"images (the k repeated){_rehearsal_clause(settings.get('rehearsal_images', 0))}. "
        "Pooled vessel IoU on the split's test images, mean ± standard deviation over splits:",
        "",
        "| real labels k | from simulation | from scratch |",
        "| ---: | ---: | ---: |",
    ]
    for k in counts:
        lines.append(
            f"| {k} | {_spread(summary['simulation'].get(str(k)))} | "
            f"{_spread(summary['scratch'].get(str(k)))} |"
        )
    lines += [
        "",
        pretraining_verdict(summary),
        "",
        f"![few-label curve]({CURVE_PNG})",
        "",
        f"![examples]({EXAMPLES_PNG})",
        "",
        "## Realism",
        "",
        "The simulated frames against the real images, measured alike (`realism/`):",
        "",
        *realism.to_markdown(),
        "",
        "![simulated and real](realism/sim_vs_real.png)",
        "",
    ]
    return lines


def save_curve_png(path: Path, results: Mapping) -> Path:
    """IoU against k for both initialisations: mean over splits with its spread as bars, and
    every split's run as a faint dot."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6.5, 4.2))
    axes = figure.subplots()
    styles = {"simulation": ("tab:blue", "from simulation"), "scratch": ("tab:orange", "scratch")}
    for initialisation, (colour, label) in styles.items():
        entries = results["curve_summary"][initialisation]
        ks = sorted(map(int, entries))
        means = [entries[str(k)]["mean"] for k in ks]
        stds = [entries[str(k)]["std"] for k in ks]
        axes.errorbar(ks, means, yerr=stds, color=colour, marker="o", capsize=3, label=label)
        runs = [p for p in results["curve"] if p["initialisation"] == initialisation]
        axes.scatter(
            [p["labels"] for p in runs], [p["iou"] for p in runs], color=colour, alpha=0.3, s=10
        )
    axes.set(xlabel="real labelled images k", ylabel="vessel IoU (real test images)", ylim=(0, 1))
    axes.set_xscale("symlog", linthresh=5)
    axes.set_xticks(results["settings"]["label_counts"])
    axes.set_xticklabels([str(k) for k in results["settings"]["label_counts"]])
    axes.grid(alpha=0.3)
    axes.legend()
    axes.set_title("fine-tuning on k real images")
    figure.text(0.5, 0.01, credit(results["real_folder"]), ha="center", fontsize=8)
    figure.tight_layout(rect=(0, 0.04, 1, 1))
    figure.savefig(path, dpi=100)
    return path


def save_examples_png(
    path: Path,
    images: FolderImages,
    examples: Mapping[tuple[str, int], Sequence[np.ndarray]],
    real_folder: str,
) -> Path:
    """Real test `images` (rows) under the models of the smallest, a middle and the largest
    k (columns; `examples` holds each model's labels of them): the prediction tinted, the
    true vessels outlined."""
    from matplotlib.figure import Figure

    from resus.segmentation.evaluate import overlay

    counts = sorted({k for _, k in examples})
    middle = (
        LABELS_WITH_PRETRAINING if LABELS_WITH_PRETRAINING in counts else counts[len(counts) // 2]
    )
    shown = {counts[0], middle, counts[-1]}
    columns = sorted(
        (key for key in examples if key[1] in shown),
        key=lambda key: (key[1], key[0] != "simulation"),
    )
    rows = range(len(images))
    figure = Figure(figsize=(2.4 * len(columns), 2.5 * len(rows) + 0.4))
    panels = figure.subplots(len(rows), len(columns), squeeze=False)
    for row, index in zip(panels, rows, strict=True):
        for panel, key in zip(row, columns, strict=True):
            picture = overlay(images.images[index], images.labels[index], examples[key][index])
            panel.imshow(picture)
            panel.set_axis_off()
            initialisation, k = key
            title = "sim only" if k == 0 else f"{initialisation}, k={k}"
            panel.set_title(f"{images.names[index]}: {title}", fontsize=7)
    figure.suptitle("real test images: prediction tinted, true vessels outlined", fontsize=9)
    figure.text(0.5, 0.005, credit(real_folder), ha="center", fontsize=7)
    figure.tight_layout(rect=(0, 0.02, 1, 1))
    figure.savefig(path, dpi=90)
    return path
