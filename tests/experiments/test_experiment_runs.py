"""`resus experiment`: tiny end-to-end runs of both tables, their reports, and the CLI's errors."""

import dataclasses
import json
import re
import statistics
import subprocess
import sys

import numpy as np
import pytest
import torch
from tiny_experiment import TINY

from resus.experiments.tables import (
    RunOptions,
    run_phantom_experiment,
    run_subjects_experiment,
)

pytestmark = pytest.mark.slow  # the demo and experiments run whole pipelines

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores


def numbers(line: str) -> list[float]:
    return [float(x) for x in re.findall(r"\d+\.\d{3}", line)]


@pytest.fixture(scope="module")
def subjects_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("subjects")
    options = RunOptions(out / "report", out / "data", seed=3, device="cpu", jobs=2, progress=False)
    results = run_subjects_experiment(TINY, options, regimes=("us", "imagenet", "resus"))
    return options, results


def test_subjects_report_table_equals_results_json(subjects_run):
    options, results = subjects_run
    saved = json.loads((options.out / "results.json").read_text())
    assert saved == json.loads(json.dumps(results.to_dict()))
    regimes = saved["loso"]["regimes"]
    assert regimes["imagenet"]["status"] == "not run"
    report = (options.out / "report.md").read_text()
    table = report.split("| held-out subject | us | resus |")[1].split("\n\n")[0].splitlines()
    subjects = saved["loso"]["subjects"]
    assert subjects == ["default/0", "default/1", "default/2"]
    assert saved["seeds"] == [3, 4]
    for subject in subjects:
        row = next(line for line in table if line.startswith(f"| {subject} |"))
        expected = []
        for regime in ("us", "resus"):
            cell = regimes[regime]["iou"][subject]
            seeds = [run["mean"] for run in cell["runs"]]
            assert cell["mean_std"] == pytest.approx(statistics.stdev(seeds))
            expected += [round(cell["mean"], 3), round(cell["mean_std"], 3)]
        assert numbers(row) == expected
    average = next(line for line in table if line.startswith("| **average**"))
    assert numbers(average) == [
        round(regimes[r]["mean_over_subjects"][key], 3)
        for r in ("us", "resus")
        for key in ("mean", "mean_std")
    ]
    assert "| p vs resus |" in report and "imagenet: not run" in report
    (mean,) = [c for c in saved["loso"]["comparisons"] if c["metric"] == "mean"]
    assert mean["n"] == 6  # 3 held-out subjects x 2 seeds, paired
    assert f"| verdict vs resus | {mean['verdict']} |" in report
    assert "subjects_differ_enough" in saved["generalisation"]
    for name in ("predictions.png", "curves_us.png", "curves_resus.png"):
        assert (options.out / name).stat().st_size > 1000


def test_no_test_subject_reslice_reaches_training(subjects_run):
    """Each fold trains on the other subjects' frames (less validation) and reslices only."""
    _, results = subjects_run
    counts = {scan.subject: scan for scan in results.images}
    fraction = TINY.training.validation_fraction
    for subject in counts:
        others = [c for s, c in counts.items() if s != subject]
        frames = sum(c.frames - min(max(1, round(fraction * c.frames)), c.frames - 1)
                     for c in others)  # fmt: skip
        reslices = sum(c.reslices for c in others)
        assert results.training_images["us"][subject] == frames
        assert results.training_images["resus"][subject] == frames + reslices


def test_phantom_report_table_equals_results_json(tmp_path):
    options = RunOptions(tmp_path / "report", tmp_path / "data", device="cpu", progress=False)
    results = run_phantom_experiment(TINY, options)
    saved = json.loads((options.out / "results.json").read_text())
    assert saved["seeds"] == [0, 1]
    report = (options.out / "report.md").read_text()
    for trained_on in ("frames", "frames + reslices"):
        row = results.iou[trained_on]
        line = next(x for x in report.splitlines() if x.startswith(f"| {trained_on} | "))
        expected = []
        for test in ("frames", "frames + reslices"):
            runs = [run.mean for run in row[test].runs]
            assert len(runs) == 2 and row[test].mean == pytest.approx(sum(runs) / 2)
            assert row[test].mean_std == pytest.approx(statistics.stdev(runs))
            expected += [round(row[test].mean, 3), round(row[test].mean_std, 3)]
        assert numbers(line) == expected
    for comparison in saved["comparisons"]["frames"]:
        assert (comparison["a"], comparison["b"]) == ("frames + reslices", "frames")
        assert f"**{comparison['verdict']}**" in report
    assert saved["scans"]["B"]["reslices"] > 0
    assert (options.out / "predictions.png").is_file()


@pytest.mark.parametrize("kept", ["us", "resus"])
def test_subjects_report_is_written_whichever_regimes_ran(subjects_run, tmp_path, kept):
    """Without resus there is nothing to compare against (no p columns); without us no
    generalisation check: either way the report is written, as `--regimes us,aug` asks."""
    from resus.experiments.report import ReportFigures, write_subjects_report
    from resus.experiments.tables import Example

    _, results = subjects_run
    loso = dataclasses.replace(results.loso, iou={kept: results.loso.iou[kept]})
    only = dataclasses.replace(
        results,
        loso=loso,
        validation_iou={kept: results.validation_iou[kept]},
        training_images={kept: results.training_images[kept]},
        generalisation=results.generalisation if kept == "us" else None,
    )
    truth = np.zeros((32, 32), np.uint8)
    truth[8:16, 8:16] = 1
    example = Example("held-out frame", truth * 200, truth, {kept: truth})
    write_subjects_report(tmp_path, only, ReportFigures([example], {}))
    report = (tmp_path / "report.md").read_text()
    assert f"| held-out subject | {kept} |" in report
    assert ("p vs resus" in report) == (kept == "resus")


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["subjects", "--preset", "huge"], "--preset: unknown preset 'huge'"),
        (["subjects", "--subjects", "1"], "--subjects: leave-one-subject-out needs at least 2"),
        (["subjects", "--subjects", "a-b"], "--subjects: expected e.g. 3, 0-7 or 0,2,5"),
        (["subjects", "--regimes", "us,magic"], "--regimes: expected a comma list"),
        (["phantom", "--executor", "spark"], "--executor: unknown executor 'spark'"),
        (["phantom", "--seeds", "1"], "--seeds: ExperimentPreset.repeats must be at least 2"),
        (["phantom", "--phantom", "nosuch"], "--phantom: ScanSettings.phantom: unknown phantom"),
        (["subjects", "--scanner", "x"], "--scanner: ScanSettings.scanner: unknown scanner"),
    ],
)
def test_cli_bad_input_is_one_line(tmp_path, arguments, message):
    command = [sys.executable, "-c", "from resus.cli.app import main; main()", "experiment"]
    done = subprocess.run(
        [*command, *arguments, "--out", str(tmp_path / "out")], capture_output=True, text=True
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and message in done.stderr
    assert not (tmp_path / "out").exists()
