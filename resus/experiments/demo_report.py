"""The demo's report.md, written from summary.json's numbers only, with the pictures beside it.

Every number is printed with `number()` (three decimals) so that a reader, or a test, can find
each value of summary.json in the report exactly as it is rounded there. IoUs are printed as
mean ± standard deviation over the training seeds, with each seed's value, and the regimes'
comparisons as the experiments' reports print them (`resus.experiments.report`).
"""

from __future__ import annotations

from collections.abc import Sequence

from resus.experiments.report import SPREAD_RULE, comparison_text, seeds_text, spread_text
from sim.labels import VESSEL_CLASSES

VESSELS = tuple(VESSEL_CLASSES)
SOURCE_TITLES = {
    "ground_truth": "true labels",
    "us": "U-Net, frames only",
    "resus": "U-Net, frames + RESUS reslices",
}
REGIME_TITLES = {"us": "frames only", "resus": "frames + RESUS reslices"}


def number(value: float | None, digits: int = 3) -> str:
    """A figure as the report prints it; "n/a" for a missing one."""
    return "n/a" if value is None else f"{value:.{digits}f}"


def render_report(summary: dict, timings: dict) -> str:
    """Markdown report of one demo run (`timings`: timings.json's wall times)."""
    lines = [
        "# RESUS demo report",
        "",
        "Every number here is read from `summary.json` beside this file (wall times from",
        "`timings.json`); pictures, meshes, volumes and the rerun recording are in the same",
        "folder.",
        "",
        *_run_section(summary, timings),
        *_segmentation_section(summary),
        *_vessel_section(summary),
        *_needle_section(summary),
        *_files_section(summary["files"]),
    ]
    return "\n".join(lines) + "\n"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return [*lines, ""]


def _run_section(summary: dict, timings: dict) -> list[str]:
    settings = summary["settings"]
    frames = summary["frames"]
    stages = [[stage, number(seconds, 1)] for stage, seconds in timings["seconds"].items()]
    stages.append(["**total**", f"**{number(timings['total_seconds'], 1)}**"])
    return [
        "## What ran",
        "",
        f"- Phantom subjects {', '.join(summary['subjects'])}, each scanned by the simulated UR3e "
        f"in one {number(settings['sweep_length'] * 1e3, 1)} mm linear sweep of "
        f"{settings['image_size']} x {settings['image_size']} frames; reconstructed and resliced.",
        f"- Quick U-Nets trained (at most {settings['max_epochs']} epochs, "
        f"{seeds_text(summary['seeds'])}) on {frames['train']} frames of the other subjects, "
        f"tested on held-out subject **{summary['test_subject']}** ({frames['test']} frames).",
        "",
        *_table(["stage", "wall time (s)"], stages),
    ]


def _segmentation_section(summary: dict) -> list[str]:
    seeds = ", ".join(map(str, summary["seeds"]))
    rows = [
        [
            REGIME_TITLES.get(regime, regime),
            spread_text(iou, "artery"),
            spread_text(iou, "vein"),
            spread_text(iou, "mean"),
            ", ".join(number(run["mean"]) for run in iou["runs"]),
            ", ".join(map(str, summary["best_epoch"][regime])),
        ]
        for regime, iou in summary["iou"].items()
    ]
    header = ["model", "artery IoU", "vein IoU", "mean IoU", f"mean IoU, seeds {seeds}"]
    return [
        "## Segmentation of the held-out subject",
        "",
        f"Mean ± sample standard deviation over {seeds_text(summary['seeds'])}; paired "
        f"t-tests pair the two regimes seed by seed. {SPREAD_RULE}",
        "",
        *_table([*header, "best epochs"], rows),
        *[f"- {comparison_text(comparison)}" for comparison in summary["comparisons"]],
        "",
        f"The pictures and the vessel maps below use the seed-{summary['mapped_seed']} models.",
        "",
        "![predictions](predictions.png)",
        "",
        "Training curves: "
        + ", ".join(f"[{path}]({path})" for path in summary["files"]["curves"])
        + ".",
        "",
        "![held-out volume](volume.png)",
        "",
        "![held-out reslices](reslices.png)",
        "",
    ]


def _vessel_section(summary: dict) -> list[str]:
    rows = []
    for source, result in summary["vessels"].items():
        scores = result["scores"]
        for vessel in VESSELS:
            score = scores.get(vessel, {}) if isinstance(scores, dict) else {}
            rows.append(
                [
                    SOURCE_TITLES.get(source, source),
                    vessel,
                    number(score.get("dice")),
                    number(score.get("mean_surface_distance_mm")),
                    number(score.get("hd95_mm")),
                    number(score.get("centreline_distance_mm")),
                ]
            )
    header = ["labels from", "vessel", "Dice", "mean surface distance (mm)", "HD95 (mm)"]
    return [
        "## Vessel map of the held-out subject",
        "",
        "Label images compounded into a label volume, surfaces by marching cubes, scored against",
        "the phantom's exact geometry inside the scanned region.",
        "",
        *_table([*header, "centreline distance (mm)"], rows),
        "![vessel map from the RESUS model](vessels/resus/vessel_map.png)",
        "",
    ]


def _needle_section(summary: dict) -> list[str]:
    lines = ["## Needle insertion site", ""]
    for source, result in summary["vessels"].items():
        needle = result["needle"]
        title = SOURCE_TITLES.get(source, source)
        if not needle["safe"]:
            lines += [f"- From the {title}: {needle['reason']}", ""]
            continue
        truth = result["needle_truth"] or {}
        lines += [
            f"- From the {title}: {needle['target']} at {number(needle['angle_deg'], 0)} degrees, "
            f"entry {_point(needle['entry_mm'])} mm (robot base frame), insertion depth "
            f"{number(needle['insertion_depth_mm'])} mm, clearance from the other vessel "
            f"{number(needle['clearance_mm'])} mm. {needle['reason']}",
            f"  On the phantom's true geometry the tip is "
            f"{'inside' if truth.get('tip_in_target_lumen') else 'outside'} the {needle['target']}"
            f" lumen, and the path passes {number(truth.get('clearance_from_other_mm'))} mm from "
            "the other vessel.",
            "",
        ]
    return [*lines, "![needle over the RESUS map](vessels/resus/needle.png)", ""]


def _point(values: Sequence[float]) -> str:
    return "(" + ", ".join(number(value, 1) for value in values) + ")"


def _files_section(files: dict) -> list[str]:
    def listing(paths: Sequence[str]) -> str:
        return ", ".join(f"`{path}`" for path in paths)

    return [
        "## Files",
        "",
        f"- rerun recording: `{files['recording']}` (open with `rerun {files['recording']}`)",
        f"- volumes for 3D Slicer (NRRD): {listing(files['volumes'])}",
        f"- vessel meshes (PLY/STL in mm, GLB in m): {listing(files['meshes'])}",
        f"- sweeps (resus.sweep/1 HDF5): {listing(files['sweeps'])}",
        f"- model checkpoints: {listing(files['checkpoints'])}",
        f"- pictures: {listing([*files['pictures'], *files['vessel_pictures']])}",
        "",
    ]
