"""The plan report: a Markdown page with the checks table and three PNGs (joints over time,
a top view of the path over the phantom's vessels, coverage and holes along the sweep)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from resus.planning.coverage import station_bins
from resus.planning.imaging_checks import frame_corners
from resus.planning.planner import PlanAnalysis
from sim.labels import LABEL_NAMES, label_colour_unit
from sim.robot import kinematics
from sim.transforms import invert_pose


def checks_table(analysis: PlanAnalysis) -> str:
    """The checks as a Markdown table."""
    rows = [
        "| check | verdict | measured | where | what to change |",
        "| --- | --- | --- | --- | --- |",
    ]
    for check in analysis.checks:
        where = check.place.describe() if check.place is not None and not check.passed else ""
        advice = check.advice if not check.passed else ""
        rows.append(
            f"| {check.name} | **{check.verdict}** | {check.summary} | {where} | {advice} |"
        )
    return "\n".join(rows)


def _plot_joints(analysis: PlanAnalysis, path: Path) -> None:
    times, motion = analysis.path.times, analysis.motion
    figure = Figure(figsize=(9, 8))
    axes = figure.subplots(3, 1, sharex=True)
    for j, name in enumerate(kinematics.JOINT_NAMES):
        axes[0].plot(times, np.degrees(motion.joint_path.joints[:, j]), label=name)
        axes[1].plot(times, np.abs(motion.speeds[:, j]) / kinematics.JOINT_SPEED_LIMITS[j])
        axes[2].plot(times, np.abs(motion.torques[:, j]) / kinematics.JOINT_TORQUE_LIMITS[j])
    axes[0].set_ylabel("joint angle (deg)")
    axes[0].legend(fontsize=7, ncol=3)
    axes[1].set_ylabel("|speed| / limit")
    axes[2].set_ylabel("|torque| / limit")
    for axis in axes[1:]:
        axis.axhline(1.0, color="k", linestyle="--", linewidth=1)
    axes[2].set_xlabel("time (s)")
    figure.suptitle(f"{analysis.trajectory.name}: joints over time")
    figure.tight_layout()
    figure.savefig(path, dpi=100)


def _plot_top_view(analysis: PlanAnalysis, path: Path) -> None:
    phantom, to_phantom = analysis.phantom, invert_pose(analysis.scene.phantom_to_base)
    figure = Figure(figsize=(7, 8))
    axis = figure.subplots()
    body = phantom.mesh("body", resolution=2e-3).vertices
    axis.fill(*_footprint(body[:, :2]).T, color="0.9", label="phantom")
    for vessel in phantom.spec.vessels:
        nodes = phantom.centrelines()[vessel.name]
        axis.plot(nodes[:, 0], nodes[:, 1], color=label_colour_unit(vessel.label), linewidth=2)
        axis.annotate(vessel.name, (nodes[-1, 0], nodes[-1, 1]), fontsize=7)
    corners = to_phantom[None, :3, :3] @ frame_corners(
        analysis.frames, analysis.settings.probe
    ).transpose(0, 2, 1)
    corners = corners.transpose(0, 2, 1) + to_phantom[:3, 3]
    imaging = analysis.frames.imaging
    for corner in corners[imaging][:: max(1, imaging.sum() // 60)]:
        axis.plot(corner[[0, 2], 0], corner[[0, 2], 1], color="tab:green", alpha=0.3, linewidth=1)
    tcp = (to_phantom @ analysis.path.poses)[:, :3, 3]
    axis.plot(tcp[:, 0], tcp[:, 1], color="k", linewidth=1.5, label="TCP path")
    axis.plot(*tcp[0, :2], "ko", label="start")
    for check in analysis.checks:
        if not check.passed and check.place is not None:
            where = (to_phantom @ analysis.trajectory.pose_at(check.place.time))[:2, 3]
            axis.plot(*where, "rx", markersize=12, markeredgewidth=3)
            axis.annotate(check.name, where, color="r", fontsize=8)
    axis.set_aspect("equal")
    axis.set_xlabel("phantom x (m, patient's right)")
    axis.set_ylabel("phantom y (m, distal)")
    axis.set_title("top view: path, image planes (green), artery (red), vein (blue)")
    axis.legend(fontsize=7, loc="lower right")
    figure.tight_layout()
    figure.savefig(path, dpi=100)


def _footprint(points: np.ndarray) -> np.ndarray:
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    return points[hull.vertices]


def _plot_coverage(analysis: PlanAnalysis, path: Path) -> None:
    frames, coverage = analysis.frames, analysis.coverage
    bins = station_bins(frames, analysis.settings.probe)
    figure = Figure(figsize=(9, 5))
    axes = figure.subplots(2, 1, sharex=True)
    for c, label in enumerate(coverage.labels):
        shown = frames.imaging & coverage.seen[:, c]
        axes[0].scatter(bins[shown], np.full(shown.sum(), c), s=4, color=label_colour_unit(label))
    axes[0].set_yticks(range(len(coverage.labels)), [LABEL_NAMES[k] for k in coverage.labels])
    axes[0].set_title("target vessels in view, by station along the sweep (1 mm bins)")
    pair = analysis.holes.pair_fraction
    valid = np.isfinite(pair)
    axes[1].plot(bins[:-1][valid], pair[valid], ".", markersize=3)
    axes[1].set_ylabel("hole fraction between frames")
    axes[1].set_xlabel("station (mm along the sweep)")
    figure.tight_layout()
    figure.savefig(path, dpi=100)


def write_report(directory: Path, analysis: PlanAnalysis, simulated: str | None = None) -> Path:
    """Write report.md and its PNGs into `directory`; returns the Markdown path."""
    directory.mkdir(parents=True, exist_ok=True)
    _plot_joints(analysis, directory / "joints.png")
    _plot_top_view(analysis, directory / "top_view.png")
    _plot_coverage(analysis, directory / "coverage.png")
    trajectory = analysis.trajectory
    verdict = "every check passes" if analysis.passed else "SOME CHECKS FAIL"
    lines = [
        f"# Scan plan: {trajectory.name} ({verdict})",
        "",
        f"Scene phantom `{analysis.scene.phantom}`, subject {analysis.scene.subject}; "
        f"{len(trajectory.waypoints)} waypoints, path {trajectory.path_length * 1e3:.1f} mm, "
        f"{trajectory.duration:.1f} s at {trajectory.speed * 1e3:.1f} mm/s, "
        f"{trajectory.frame_rate:.0f} frames/s, voxel {analysis.settings.voxel_size * 1e3:.2f} mm.",
        f"Pattern: `{trajectory.pattern}`",
        "",
        checks_table(analysis),
        "",
        f"Expected hole fraction (planned planes rasterised): {analysis.holes.fraction:.2%}.",
    ]
    if simulated is not None:
        lines += ["", simulated]
    lines += [
        "",
        "![joints](joints.png)",
        "",
        "![top view](top_view.png)",
        "",
        "![coverage](coverage.png)",
        "",
    ]
    path = directory / "report.md"
    path.write_text("\n".join(lines))
    return path
