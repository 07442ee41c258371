"""Usage errors of every command: one `error:` line (plus click's usage hint), exit 2, never a
traceback; `--help`, `--version` and `python -m resus`.

Most cases call `resus.cli.app.main` in this process (a fresh interpreter per case would cost
a second or two each); a handful run the command line for real, as a user would.
"""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points

import pytest
import typer
from cli_runner import resus, run_main

from resus import __version__
from resus.cli.app import app


def command_paths() -> dict[tuple[str, ...], object]:
    """Every runnable command, by the words that call it (e.g. ('sweep', 'info')), as the root
    app's help and its groups' help list them."""
    paths: dict[tuple[str, ...], object] = {}

    def walk(command: object, path: tuple[str, ...]) -> None:
        subcommands = getattr(command, "commands", None)
        if subcommands is None:
            paths[path] = command
            return
        for name, subcommand in subcommands.items():
            walk(subcommand, (*path, name))

    walk(typer.main.get_command(app), ())
    return paths


COMMANDS = command_paths()
REQUIRED = {path: [p for p in command.params if p.required] for path, command in COMMANDS.items()}

SIM_SCAN = ["--robot", "sim", "--probe", "sim", "--trajectory", "t", "--out", "s"]
"""The flags `resus scan` needs, for a simulated scan."""

BAD_VALUES: dict[tuple[str, ...], tuple[list[str], str]] = {
    ("demo",): (["--epochs", "many"], "Invalid value for '--epochs'"),
    ("simulate",): (["--out", "s.h5", "--jobs", "0"], "Invalid value for '--jobs'"),
    ("reconstruct",): (["s.h5", "--out", "v.nrrd", "--seed", "x"], "Invalid value for '--seed'"),
    ("reslice",): (["v", "l", "--out", "o", "--step", "x"], "Invalid value for '--step'"),
    ("train",): (["--sweeps", "s", "--out", "o", "--seed", "1.5"], "Invalid value for '--seed'"),
    ("emulate",): (["--port-base", "x"], "Invalid value for '--port-base'"),
    ("view",): (["s.h5", "--max-reslices", "0"], "Invalid value for '--max-reslices'"),
    ("plan",): (["--out", "p.yaml", "--passes", "two"], "Invalid value for '--passes'"),
    ("scan",): ([*SIM_SCAN, "--volume-every=0"], "Invalid value for '--volume-every'"),
    ("calibrate-time",): (["s.h5", "--step", "fast"], "Invalid value for '--step'"),
    ("calibration-plan",): (["t.yaml", "--cycles", "x"], "Invalid value for '--cycles'"),
    ("vessels",): (["s.h5", "--out", "o", "--subject", "x"], "Invalid value for '--subject'"),
    ("evaluate",): (
        ["--model", "{tmp}/none.pt", "--images", "i", "--masks", "m"],
        "checkpoint not found",
    ),
    ("realism",): (
        ["--sweep", "s.h5", "--real", "r", "--out", "o", "--frames", "0"],
        "Invalid value for '--frames'",
    ),
    # `sweep info` has no option: its argument is the value that can be bad
    ("sweep", "info"): (["{tmp}/missing.h5"], "missing.h5: no such file"),
    ("sweep", "import-plus"): (["x.igs.mha", "--out", "{tmp}/no/x.h5"], "output folder"),
    ("sweep", "export-plus"): (["x.h5", "--out", "{tmp}/no/x.igs.mha"], "output folder"),
    ("sweep", "preview"): (["s.h5", "--out", "p", "--count", "0"], "Invalid value for '--count'"),
    ("sweep", "stream"): (["s.h5", "--igtl", "x"], "Invalid value for '--igtl'"),
    ("sweep", "import-ros"): (
        ["b", "--image-topic", "/us", "--calibration", "c", "--out", "{tmp}/no/x.h5"],
        "output folder",
    ),
    ("sweep", "export-ros"): (["x.h5", "--out", "{tmp}/no/x.mcap"], "output folder"),
    ("sweep", "attach-labels"): (
        ["x.h5", "--masks", "m", "--out", "{tmp}/no/x.h5"],
        "output folder",
    ),
    ("sweep", "export-labels"): (["x.h5", "--out", "{tmp}/no/labels"], "output folder"),
    ("experiment", "phantom"): (["--out", "o", "--jobs", "x"], "Invalid value for '--jobs'"),
    ("experiment", "subjects"): (["--out", "o", "--seed", "x"], "Invalid value for '--seed'"),
    ("experiment", "sim2real"): (
        ["--real", "r", "--out", "o", "--jobs", "0"],
        "Invalid value for '--jobs'",
    ),
}


def assert_usage_error(status: int, err: str, path: tuple[str, ...] | None, *fragments: str):
    """Exit 2, one `error:` line with `fragments`, then (for a usage error of the command
    `path`) click's hint naming that command; nothing else, no traceback."""
    assert status == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert lines[0].startswith("error: "), err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    if path is None:
        assert len(lines) == 1, err
    else:
        assert lines[1:] == [f"Try '{' '.join(('resus', *path))} --help' for help."], err


def ids(paths) -> list[str]:
    return [" ".join(path) for path in paths]


def test_every_command_has_a_bad_value_case():
    assert set(BAD_VALUES) == set(COMMANDS)
    assert {("sweep", "preview"), ("experiment", "subjects"), ("calibrate-time",)} <= set(COMMANDS)


def test_no_help_text_holds_brackets_the_help_renderer_would_swallow():
    """Rich reads `[...]` in a help text as markup and drops it: `[default: OUT/data]` would
    show as nothing. Defaults go in parentheses."""
    swallowed = [
        f"{' '.join(path)} {param.name}: {param.help}"
        for path, command in COMMANDS.items()
        for param in command.params
        if "[" in (getattr(param, "help", None) or "")
    ]
    assert not swallowed


@pytest.mark.parametrize("path", list(COMMANDS), ids=ids(COMMANDS))
def test_unknown_option(monkeypatch, capsys, path):
    status, _, err = run_main(monkeypatch, capsys, *path, "--no-such-option")
    assert_usage_error(status, err, path, "No such option: --no-such-option")


WITH_REQUIRED = [path for path, params in REQUIRED.items() if params]


@pytest.mark.parametrize("path", WITH_REQUIRED, ids=ids(WITH_REQUIRED))
def test_missing_required_argument_or_option(monkeypatch, capsys, path):
    status, _, err = run_main(monkeypatch, capsys, *path)
    assert_usage_error(status, err, path, "Missing ")
    assert err.startswith(("error: Missing argument '", "error: Missing option '--")), err


@pytest.mark.parametrize("path", list(BAD_VALUES), ids=ids(BAD_VALUES))
def test_bad_value(monkeypatch, capsys, tmp_path, path):
    args, fragment = BAD_VALUES[path]
    status, _, err = run_main(monkeypatch, capsys, *path, *(a.format(tmp=tmp_path) for a in args))
    usage_error = fragment.startswith("Invalid value")  # from click, with its usage hint
    assert_usage_error(status, err, path if usage_error else None, fragment)


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["calibrate-time", "s.h5", "--range", "0.5:-0.5"], "--range: expected LOW:HIGH"),
        (["simulate", "--out", "o", "--subjects", "3-1"], "--subjects: expected e.g. 3"),
        (
            ["simulate", "--out", "o.h5", "--frame-rate", "-5"],
            "--frame-rate: LinearPattern.frame_rate must be positive, got -5.0",
        ),
        (["simulate", "--out", "o.h5", "--scanner", "vascullar"], "--scanner: unknown scanner"),
        (
            ["simulate", "--out", "o.h5", "--scanner", "no/such.yaml"],
            "--scanner: no/such.yaml: scanner preset file not found",
        ),
        (["plan", "--out", "p.yaml", "--pattern", "spiral"], "--pattern must be one of linear"),
        (
            ["scan", *SIM_SCAN, "--max-force", "0"],
            "--max-force: SafetyLimits.max_force must be positive, got 0.0",
        ),
        (["emulate", "--arm", "hydraulic"], "--arm must be one of mujoco, kinematic"),
        (["emulate", "--fault", "meltdown"], "--fault"),
        (
            ["calibration-plan", "t.yaml", "--direction", "0,0"],
            "--direction: the sweep direction must be a non-zero (x, y) vector",
        ),
        (
            ["emulate", "--port-base", "70000"],
            "--port-base: port base 70000 puts the ports at 99999-100004, outside 1-65535",
        ),
        (["reconstruct", "s.h5", "--out", "v.nrrd", "--voxels", "8,8"], "--voxels: expected 3"),
        (
            ["reconstruct", "s.h5", "--out", "v.nrrd", "--grid", "sphere"],
            "--grid: GridSettings.kind must be one of ransac, aabb, got 'sphere'",
        ),
        (
            ["reconstruct", "s.h5", "--out", "v.nrrd", "--spacing", "0"],
            "--spacing: GridSettings.spacing must be positive, got 0.0",
        ),
        (  # before the sweep is read and reconstructed
            ["reconstruct", "s.h5", "--out", "v.txt"],
            "v.txt: volume files must end in .nrrd, .nhdr, .mha or .mhd",
        ),
        (
            ["train", "--sweeps", "s", "--out", "o", "--average-epochs", "9"],
            "--average-epochs: TrainingPreset.weight_averaging_epochs must be in [0, max_epochs",
        ),
    ],
)
def test_a_refused_flag_value_is_one_line_naming_the_flag(monkeypatch, capsys, args, fragment):
    status, _, err = run_main(monkeypatch, capsys, *args)
    assert_usage_error(status, err, None, fragment)


@pytest.mark.parametrize("path", [(), *COMMANDS], ids=["resus", *ids(COMMANDS)])
def test_help_works_everywhere(monkeypatch, capsys, path):
    status, out, err = run_main(monkeypatch, capsys, *path, "--help")
    assert status == 0 and "Usage" in out and not err


@pytest.mark.parametrize("group", [(), ("sweep",), ("experiment",)], ids=["resus", "sweep", "exp"])
def test_a_group_without_a_command_shows_its_help(monkeypatch, capsys, group):
    status, out, err = run_main(monkeypatch, capsys, *group)
    assert status == 2 and "Usage" in out + err and "Traceback" not in err


def test_ctrl_c_is_one_line_and_status_130(monkeypatch, capsys, tmp_path):
    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr("resus.sweep.summary.summarize_sweep", interrupted)
    status, _, err = run_main(monkeypatch, capsys, "sweep", "info", tmp_path / "s.h5")
    assert status == 130 and err == "error: interrupted\n"


def test_version_in_process(monkeypatch, capsys):
    status, out, _ = run_main(monkeypatch, capsys, "--version")
    assert status == 0 and out == f"resus {__version__}\n"


def test_console_script_is_main():
    (script,) = entry_points(group="console_scripts", name="resus")
    assert script.value == "resus.cli.app:main"


# -- the real command line, in a fresh interpreter -----------------------------------------


def test_unknown_command_for_real():
    done = resus("nosuch")
    assert_usage_error(done.returncode, done.stderr, (), "No such command 'nosuch'")


def test_missing_argument_for_real():
    done = resus("reconstruct")
    assert_usage_error(done.returncode, done.stderr, ("reconstruct",), "Missing argument 'SWEEP'")


def test_out_of_range_option_for_real():
    done = resus("sweep", "preview", "s.h5", "--count", "0")
    assert_usage_error(done.returncode, done.stderr, ("sweep", "preview"), "'--count'")


def test_version_for_real():
    done = resus("--version")
    assert done.returncode == 0 and done.stdout == f"resus {__version__}\n" and not done.stderr


def test_python_dash_m_resus():
    done = subprocess.run(
        [sys.executable, "-m", "resus", "--version"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0 and done.stdout == f"resus {__version__}\n"
