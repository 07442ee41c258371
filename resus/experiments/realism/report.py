"""`resus realism`'s report: realism.json, realism.md and its two figures."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.errors import ResusError
from resus.experiments.realism.comparison import TABLE, RealismComparison
from resus.experiments.realism.images import REAL_CREDIT, ImageSet, imaged_region
from resus.experiments.realism.line_orientation import ANGLE_BIN_DEGREES, LINE_SCALE, LINE_SHARE
from resus.experiments.realism.measurement import compare
from resus.experiments.realism.stats import DEPTH_BANDS, GREY_LEVELS, RealismSettings, RealismStats
from resus.experiments.realism.vessels import ELONGATED_ASPECT
from resus.indices import evenly_spaced

if TYPE_CHECKING:
    from matplotlib.figure import Figure

REALISM_JSON = "realism.json"
REALISM_MD = "realism.md"
SIM_VS_REAL_PNG = "sim_vs_real.png"
HISTOGRAMS_PNG = "histograms.png"
OUTLINE_COLOUR = "yellow"
"""Vessel outline in the figures (the real masks do not tell artery from vein)."""
SET_COLOURS = {"simulated": "tab:orange", "real": "tab:blue"}


def save_sim_vs_real_png(
    path: str | Path,
    simulated: ImageSet,
    real: ImageSet,
    count: int = 4,
    settings: RealismSettings | None = None,
) -> Path:
    """`count` simulated images (top row) over `count` real ones with a vessel (bottom row),
    evenly chosen, each cut to its imaged area with its vessels outlined; credited."""
    from matplotlib.figure import Figure

    blank_fraction = (settings or RealismSettings()).blank_fraction
    rows = [(simulated, _with_vessels(simulated, count)), (real, _with_vessels(real, count))]
    columns = max(len(indices) for _, indices in rows)
    figure = Figure(figsize=(3.0 * columns, 5.9))
    panels = figure.subplots(2, columns, squeeze=False)
    for row, (images, indices) in zip(panels, rows, strict=True):
        for panel in row:
            panel.set_axis_off()
        for panel, index in zip(row, indices, strict=False):
            region = imaged_region(images.images[index], blank_fraction)
            panel.imshow(images.images[index][region], cmap="gray", vmin=0, vmax=255)
            vessel = images.vessels[index][region]
            if vessel.any():
                panel.contour(vessel, levels=[0.5], colors=OUTLINE_COLOUR, linewidths=0.8)
            panel.set_title(f"{images.name}: {images.sources[index]}", fontsize=8)
    figure.suptitle("simulated (top) and real (bottom) B-mode images, vessel lumens outlined")
    figure.text(0.5, 0.01, REAL_CREDIT, ha="center", fontsize=9)
    figure.tight_layout(rect=(0, 0.03, 1, 1))
    return _save(figure, Path(path), 90)


def _with_vessels(images: ImageSet, count: int) -> list[int]:
    """`count` evenly spaced indices of the images that show a vessel (of all, if none do)."""
    showing = [i for i, vessel in enumerate(images.vessels) if vessel.any()] or list(
        range(len(images))
    )
    return [showing[i] for i in evenly_spaced(len(showing), count)]


def save_histograms_png(path: str | Path, comparison: RealismComparison) -> Path:
    """Both sets' grey-level histograms overlaid, bars of the table's grey figures and of the
    lumen/tissue ratio, their depth profiles, their vessels' aspect distributions and the
    angles of their tissue's bright lines; credited."""
    from matplotlib.figure import Figure

    sets = (comparison.simulated, comparison.real)
    figure = Figure(figsize=(27, 4.4))
    histogram, greys, ratios, depths, aspects, lines = figure.subplots(
        1, 6, width_ratios=(2.2, 2.0, 0.9, 1.4, 1.6, 1.6)
    )
    for stats in sets:
        colour = SET_COLOURS.get(stats.name)
        label = f"{stats.name} ({stats.images} images)"
        histogram.step(
            np.arange(GREY_LEVELS), stats.histogram, where="mid", color=colour, label=label
        )
        histogram.axvline(stats.mean, color=colour, linestyle="--", linewidth=0.8)
    histogram.set_xlim(0, GREY_LEVELS - 1)
    histogram.set_xlabel("grey level (imaged area)")
    histogram.set_ylabel("share of pixels")
    histogram.set_title("grey-level histograms (dashed: means)")
    histogram.legend()
    figures = [(label, get) for label, get, _ in TABLE[:4]]
    width = 0.38
    for offset, stats in zip((-width / 2, width / 2), sets, strict=True):
        values = [get(stats) or 0.0 for _, get in figures]
        colour = SET_COLOURS.get(stats.name)
        greys.bar(np.arange(len(figures)) + offset, values, width, color=colour, label=stats.name)
        ratios.bar(offset, stats.lumen_tissue or 0.0, width, color=colour, label=stats.name)
        profile = [np.nan if grey is None else grey for grey in stats.depth_profile]
        depths.plot(profile, np.arange(DEPTH_BANDS) + 1, "o-", color=colour, label=stats.name)
        if stats.vessel_shapes is not None:
            ordered = np.sort(stats.vessel_shapes.aspects)
            shares = np.arange(1, len(ordered) + 1) / len(ordered)
            label = f"{stats.name} ({len(ordered)} vessels)"
            aspects.step(ordered, shares, where="post", color=colour, label=label)
        if stats.line_angle_shares is not None:
            edges = np.arange(len(stats.line_angle_shares) + 1) * ANGLE_BIN_DEGREES
            density = np.array(stats.line_angle_shares) / ANGLE_BIN_DEGREES
            lines.stairs(density, edges, color=colour, label=stats.name)
    greys.set_xticks(np.arange(len(figures)), [label for label, _ in figures])
    greys.set_ylim(0, GREY_LEVELS - 1)
    greys.set_ylabel("grey level")
    greys.set_title("grey levels")
    greys.legend()
    ratios.set_xticks([0], ["lumen/tissue"])
    ratios.set_ylim(0, 1)
    ratios.set_title("lumen/tissue mean")
    depths.set_ylim(DEPTH_BANDS + 0.5, 0.5)  # the face at the top, as in the image
    depths.set_yticks(np.arange(DEPTH_BANDS) + 1)
    depths.set_xlim(0, GREY_LEVELS - 1)
    depths.set_xlabel("tissue mean grey")
    depths.set_ylabel("depth fifth of the imaged area")
    depths.set_title("grey by depth")
    depths.legend()
    aspects.axvline(ELONGATED_ASPECT, color="grey", linestyle=":", linewidth=0.8)
    aspects.set_xscale("log")
    aspects.set_xlim(1, 20)
    aspects.set_ylim(0, 1)
    aspects.set_xlabel("vessel aspect (length / width)")
    aspects.set_ylabel("share of vessel regions at or below")
    aspects.set_title("vessel shapes (dotted: flattened)")
    aspects.legend()
    lines.set_yscale("log")
    lines.set_xlim(0, 90)
    lines.set_xlabel("normal to the beam (degrees; 0: a line across it)")
    lines.set_ylabel("share of bright-line pixels per degree")
    lines.set_title("which way the tissue's bright lines run")
    lines.legend()
    figure.suptitle(f"simulated vs real grey levels   ({REAL_CREDIT})")
    figure.tight_layout()
    return _save(figure, Path(path), 90)


def _save(figure: Figure, path: Path, dpi: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=dpi)
    return path


def write_realism_report(
    out: str | Path,
    simulated: ImageSet,
    real: ImageSet,
    settings: RealismSettings | None = None,
    sources: Mapping[str, object] | None = None,
) -> RealismComparison:
    """Measure both sets and write realism.json, realism.md, sim_vs_real.png and
    histograms.png into `out`; `sources` (what was read) goes into both texts."""
    out = Path(out)
    comparison = compare(simulated, real, settings)
    summary = {"sources": dict(sources or {}), **comparison.to_dict()}
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / REALISM_JSON).write_text(json.dumps(summary, indent=2) + "\n")
        save_sim_vs_real_png(out / SIM_VS_REAL_PNG, simulated, real, settings=comparison.settings)
        save_histograms_png(out / HISTOGRAMS_PNG, comparison)
        lines = _report_lines(comparison, summary["sources"])
        (out / REALISM_MD).write_text("\n".join(lines) + "\n")
    except OSError as error:
        raise ResusError(
            f"cannot write the report there ({error.strerror or error})", out
        ) from None
    return comparison


def _dynamic_range(stats: RealismStats) -> str:
    """The set's display dynamic range as the report words it."""
    speckle = stats.speckle
    if speckle is None or speckle.dynamic_range_db is None:
        return "unknown"
    return f"{speckle.dynamic_range_db:g} dB"


def _report_lines(comparison: RealismComparison, sources: Mapping[str, object]) -> list[str]:
    settings = comparison.settings
    sim, real = comparison.simulated, comparison.real
    return [
        "# Realism: simulated against real B-mode images",
        "",
        f"Simulated: {sim.images} frames ({sim.pixels:,} imaged pixels); real: {real.images} "
        f"images ({real.pixels:,} imaged pixels).",
        "",
        f"Credit: {REAL_CREDIT}.",
        "",
        *comparison.to_markdown(),
        "",
        "Grey levels are pooled over the imaged area of every image (border rows and columns "
        f"with at least {settings.blank_fraction:.0%} black pixels stripped); lumen = vessel "
        "pixels, tissue = the rest of the imaged area. Speckle: grey levels in "
        f"{settings.patch} px tissue windows at least {settings.vessel_margin:g} px from a "
        "vessel, homogeneous and unclipped (the Rayleigh reference is the 5.57 dB std of "
        f"log-compressed speckle at the simulated display's {_dynamic_range(sim)} dynamic "
        "range; real images do not record theirs); grain: autocorrelation FWHM over "
        f"{settings.grain_patch} px windows, in each set's own pixels, and again with every "
        f"image resized to the network's {settings.network_size} x {settings.network_size} px "
        f"input, over {settings.network_grain_patch} px windows. Bright lines: ridges "
        f"of the Hessian at a sigma of {LINE_SCALE:.1%} of the imaged height, the strongest "
        f"{LINE_SHARE:.0%} of each image's tissue clear of the vessels, by the angle of their "
        "normal to the beam (a line across the beam: 0 degrees). Vessel shapes: each "
        f"connected vessel region of at least {settings.min_vessel_area:.2%} of its image's "
        "imaged area; aspect = sqrt of its second moments' eigenvalue ratio (length over "
        "width), area and centre depth as shares of the imaged area and height; outline: "
        "each uncut region's IoU with the uniform ellipse of its second moments; placement: "
        "each image's vessel centroid (mean column of its regions' pixels) off the middle, as "
        "a share of the width; cut: regions touching the imaged area's side or bottom. Per "
        "vessel: "
        f"the lumen's interior (more than {settings.wall_band:.1%} of the imaged height inside "
        "its edge) and the wall band (that wide, outside it; beside the lumen or above and "
        "below it by the wall's normal) over the tissue two to four such bands out; the "
        "interior's middle third of columns over its outer thirds.",
        "",
        f"![simulated and real images]({SIM_VS_REAL_PNG})",
        f"![grey-level histograms]({HISTOGRAMS_PNG})",
        "",
        "## Sources",
        "",
        *(f"- {key}: {value}" for key, value in sources.items()),
    ]
