"""The simulator's fingerprint: the same files give the same hash anywhere, any change another."""

from __future__ import annotations

import shutil
from pathlib import Path

from sim.assets import assets_dir

import sim
from sim.fingerprint import simulator_fingerprint, tree_fingerprint


def copy_simulator(to: Path) -> tuple[Path, Path]:
    """The `sim` package and the assets copied under `to`, without compiled bytecode."""
    ignore = shutil.ignore_patterns("__pycache__")
    source = shutil.copytree(Path(sim.__file__).parent, to / "sim", ignore=ignore)
    assets = shutil.copytree(assets_dir(), to / "assets", ignore=ignore)
    return source, assets


def test_a_copy_elsewhere_has_the_installed_simulators_fingerprint(tmp_path):
    source, assets = copy_simulator(tmp_path)
    (source / "__pycache__").mkdir(exist_ok=True)
    (source / "__pycache__" / "stale.py").write_text("x = 1\n")  # not a source file
    (assets / "notes.txt").write_text("not read by the simulator\n")
    assert tree_fingerprint((source, assets)) == simulator_fingerprint()
    assert len(simulator_fingerprint()) == 16


def test_a_changed_module_a_changed_asset_or_a_new_module_changes_it(tmp_path):
    source, assets = copy_simulator(tmp_path)
    before = tree_fingerprint((source, assets))
    scanner = source / "ultrasound" / "scanner.py"
    scanner.write_text(scanner.read_text().replace("(-4.0, 4.0)", "(-2.0, 6.0)", 1))
    knob = tree_fingerprint((source, assets))
    spec = assets / "phantoms" / "femoral.yaml"
    spec.write_text(spec.read_text() + "\n# a comment is a change too\n")
    asset = tree_fingerprint((source, assets))
    (source / "extra.py").write_text("")
    module = tree_fingerprint((source, assets))
    assert len({before, knob, asset, module}) == 4
    # a file's path counts, not only its bytes: the same bytes moved give another fingerprint
    (source / "extra.py").rename(source / "phantom" / "extra.py")
    assert tree_fingerprint((source, assets)) not in {before, knob, asset, module}


EXTRA_CLASS = '''

class Extra:
    """Said once."""

    x: int = 1
    """An attribute's docstring."""
'''


def test_comments_docstrings_and_layout_of_a_module_do_not_change_it(tmp_path):
    """What a module does counts, not how it is written down: a rewritten docstring (of the
    module, a class, an attribute), a comment or a reflowed import keeps the fingerprint; new
    code and a changed string that the code uses do not."""
    source, assets = copy_simulator(tmp_path)
    before = tree_fingerprint((source, assets))
    settings = source / "ultrasound" / "settings.py"
    text = settings.read_text()
    reworded = text.replace(text.split('"""')[1], "Reworded.\n\nA second paragraph.", 1)
    reworded = reworded.replace(
        "from __future__ import annotations",
        "from __future__ import (\n    annotations,  # a comment\n)",
        1,
    )
    assert reworded != text
    settings.write_text(reworded)
    assert tree_fingerprint((source, assets)) == before
    settings.write_text(reworded + EXTRA_CLASS)
    with_extra = tree_fingerprint((source, assets))
    assert with_extra != before  # a new class is code
    settings.write_text(
        reworded + EXTRA_CLASS.replace("Said once", "Said twice").replace("docstring", "note")
    )
    assert tree_fingerprint((source, assets)) == with_extra
    spec = source / "phantom" / "spec.py"
    code = spec.read_text()
    assert 'SIDES = ("right", "left")' in code
    spec.write_text(code.replace('SIDES = ("right", "left")', 'SIDES = ("right", "links")'))
    assert tree_fingerprint((source, assets)) not in {before, with_extra}  # a string it uses
