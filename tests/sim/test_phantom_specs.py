"""Phantom specs load, anatomy is right (sides, branches, GSV), subjects are seeded variants."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import yaml
from sim.assets import assets_dir

from sim.phantom import (
    ARTERY,
    VEIN,
    Phantom,
    PhantomSpec,
    load_phantom,
    make_subject,
    phantom_digest,
)
from sim.phantom.loader import phantoms_dir


def centreline(spec: PhantomSpec, name: str) -> np.ndarray:
    return Phantom(spec).centrelines()[name]


def with_changes(tmp_path, changes: dict, base: str = "default"):
    """Write the named spec with top-level keys replaced, return its path."""
    data = yaml.safe_load((phantoms_dir() / f"{base}.yaml").read_text())
    data.update(changes)
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_named_specs_load_from_the_assets_folder() -> None:
    assert phantoms_dir() == assets_dir() / "phantoms" and (assets_dir() / "phantoms").is_dir()
    default, leg = load_phantom("default"), load_phantom("leg")
    assert default.body.kind == "block" and default.side == "right" and not default.bones
    assert leg.body.kind == "leg" and len(leg.layers) == 3 and leg.bones and leg.bone is not None
    assert [v.name for v in default.vessels] == ["CFA", "SFA", "DFA", "CFV", "FV", "GSV"]
    assert load_phantom(phantoms_dir() / "leg.yaml").vessels == leg.vessels
    femur_top = -leg.bones[0].control_points[:, 2] - leg.bones[0].radii
    assert (femur_top >= 0.040).all()  # deep, 40+ mm


@pytest.mark.parametrize("side", ["right", "left"])
def test_artery_lies_lateral_to_the_vein(tmp_path, side: str) -> None:
    spec = load_phantom(with_changes(tmp_path, {"side": side}))
    lateral = spec.lateral_sign
    assert lateral == (1.0 if side == "right" else -1.0)
    for subject in [None, 0, 1, 2]:
        variant = spec if subject is None else make_subject(spec, subject)
        lines = Phantom(variant).centrelines()
        for artery, vein in [("CFA", "CFV"), ("SFA", "FV")]:
            n = min(len(lines[artery]), len(lines[vein]))
            gap = lateral * (lines[artery][:n, 0] - lines[vein][:n, 0])
            assert (gap > 0.005).all()


def test_the_transposed_variant_puts_the_artery_medial_and_changes_nothing_else() -> None:
    """`extends: femoral` lays only the changed keys over the femoral spec."""
    femoral, transposed = load_phantom("femoral"), load_phantom("femoral-transposed")
    assert transposed.layers == femoral.layers and transposed.mechanics == femoral.mechanics
    ranges = dict(transposed.variation.ranges)
    assert ranges.pop("artery_vein_spacing") == (-0.014, -0.009)
    assert ranges == {
        k: v for k, v in femoral.variation.ranges.items() if k != "artery_vein_spacing"
    }
    for subject in (0, 1, 2):
        lines = Phantom(make_subject(transposed, subject)).centrelines()
        n = min(len(lines["CFA"]), len(lines["CFV"]))
        assert (lines["CFA"][:n, 0] - lines["CFV"][:n, 0] < -0.005).all()  # medial on the right


def test_extends_loops_and_unknown_bases_name_the_file(tmp_path) -> None:
    first, second = tmp_path / "a.yaml", tmp_path / "b.yaml"
    first.write_text(f"extends: {second}\nname: a\n")
    second.write_text(f"extends: {first}\nname: b\n")
    with pytest.raises(ValueError, match="`extends` loops back"):
        load_phantom(first)
    first.write_text("extends: nowhere\nname: a\n")
    with pytest.raises(ValueError, match="unknown phantom 'nowhere'"):
        load_phantom(first)


def test_the_digest_covers_the_spec_file_and_every_spec_it_extends(tmp_path) -> None:
    base, variant = tmp_path / "base.yaml", tmp_path / "variant.yaml"
    base.write_text("extends: femoral\nnoise_level: 0.3\n")
    variant.write_text(f"extends: {base}\nname: variant\n")
    texts = [
        variant.read_bytes(),
        base.read_bytes(),
        (phantoms_dir() / "femoral.yaml").read_bytes(),
    ]
    assert phantom_digest(variant) == hashlib.sha256(b"".join(texts)).hexdigest()[:16]
    assert phantom_digest("femoral") == hashlib.sha256(texts[2]).hexdigest()[:16]

    before = phantom_digest(variant)
    base.write_text("extends: femoral\nnoise_level: 0.4\n")  # edited in place, same names
    assert phantom_digest(variant) != before
    (tmp_path / "copy.yaml").write_text(variant.read_text())
    assert phantom_digest(tmp_path / "copy.yaml") == phantom_digest(variant)  # content, not path


def test_deep_femoral_artery_branches_deeper_and_lateral() -> None:
    spec = load_phantom("default")
    lines = Phantom(spec).centrelines()
    cfa, sfa, dfa = lines["CFA"], lines["SFA"], lines["DFA"]
    np.testing.assert_allclose(sfa[0], cfa[-1], atol=1e-12)  # both branches leave the CFA end
    np.testing.assert_allclose(dfa[0], cfa[-1], atol=1e-12)
    separation = np.linalg.norm(dfa[-1] - sfa[-1])
    assert separation > spec.anatomy.cfa_radius * 2  # diverged into two lumens distally
    assert dfa[-1, 2] < sfa[-1, 2] - 0.008  # deeper
    assert dfa[-1, 0] > sfa[-1, 0] + 0.005  # lateral (+x on a right leg)


def test_great_saphenous_vein_joins_the_common_femoral_vein() -> None:
    spec = load_phantom("default")
    phantom = Phantom(spec)
    gsv = phantom.centrelines()["GSV"]
    cfv_index = [v.name for v in spec.vessels].index("CFV")
    cfv_only = Phantom(
        PhantomSpec(**{**spec.__dict__, "vessels": (spec.vessels[cfv_index],), "anatomy": None})
    )
    assert cfv_only.vessel_sdf(gsv[:1], VEIN)[0] < -0.003  # starts inside the CFV lumen
    assert -gsv[-1, 2] < 0.01 < -phantom.centrelines()["FV"][-1, 2]  # ends superficial
    assert gsv[-1, 0] < phantom.centrelines()["FV"][-1, 0] - 0.01  # and medial
    assert gsv[0, 1] < spec.anatomy.bifurcation_y  # near the proximal end


def test_subjects_are_deterministic_and_differ() -> None:
    spec = load_phantom("leg")
    assert make_subject(spec, 3) == make_subject(spec, 3)
    subjects = [make_subject(spec, k) for k in range(8)]
    assert all(s.subject == k for k, s in enumerate(subjects))
    depths = [s.anatomy.artery_depth for s in subjects]
    spacings = [s.anatomy.artery_vein_spacing for s in subjects]
    bifurcations = [s.anatomy.bifurcation_y for s in subjects]
    fat = [s.layers[1].thickness for s in subjects]
    assert np.ptp(depths) > 0.005 and np.ptp(spacings) > 0.003 and np.ptp(bifurcations) > 0.02
    assert np.ptp(fat) > 0.002 and np.ptp([s.noise_level for s in subjects]) > 0.1
    assert len({s.layers[2].echogenicity for s in subjects}) == 8
    assert subjects[0].vessels != subjects[1].vessels
    assert make_subject(load_phantom("default"), 3).vessels != subjects[3].vessels


@pytest.mark.parametrize("name", ["default", "leg", "femoral"])
def test_subject_vessels_keep_the_gap(name: str) -> None:
    spec = load_phantom(name)
    for k in range(4):
        subject = make_subject(spec, k)
        phantom = Phantom(subject)
        gap = subject.variation.min_gap
        rng = np.random.default_rng(k)
        for vessel in subject.vessels:
            if vessel.label != ARTERY:
                continue
            nodes = phantom.centrelines()[vessel.name]
            radii = phantom.centreline_radii()[vessel.name]
            direction = rng.normal(size=(len(nodes), 3))
            direction /= np.linalg.norm(direction, axis=1, keepdims=True)
            outer_wall = nodes + (radii + vessel.wall_thickness)[:, None] * direction
            vein_distance = phantom.vessel_sdf(outer_wall, VEIN)
            assert (vein_distance > subject.anatomy.vein_wall + gap - 1e-6).all()
        if subject.bones:
            for vessel in subject.vessels:
                nodes = phantom.centrelines()[vessel.name]
                femur = subject.bones[0].control_points
                axis = femur[-1] - femur[0]
                t = ((nodes - femur[0]) @ axis) / (axis @ axis)
                to_axis = np.linalg.norm(nodes - (femur[0] + t[:, None] * axis), axis=1)
                assert (to_axis > subject.bones[0].radii[0] + gap).all()


def test_make_subject_rejects_misuse() -> None:
    spec = load_phantom("default")
    with pytest.raises(ValueError, match="already subject"):
        make_subject(make_subject(spec, 0), 1)
    with pytest.raises(ValueError, match=">= 0"):
        make_subject(spec, -1)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("name: [unclosed\n", "not valid YAML"),
        ("- just\n- a list\n", "a phantom spec file holds a mapping of keys, got a list"),
        ("name: x\n", "exactly one of `anatomy` or `vessels`"),
    ],
)
def test_bad_yaml_names_the_file(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as error:
        load_phantom(path)
    assert str(path) in str(error.value)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"side": "middle"}, "side must be right or left"),
        ({"colour": "red"}, "unknown key"),
        ({"body": {"kind": "sphere"}}, "body kind"),
        ({"blood": {"name": "blood"}}, "blood: missing"),
        ({"variation": {"ranges": {"artery_depth": [0.02, 0.01]}}}, "low <= high"),
        ({"variation": {"ranges": {"nerve_depth": [0.01, 0.02]}}}, "unknown key"),
        ({"anatomy": {"bifurcation_y": 0.5}}, "bifurcation_y"),
    ],
)
def test_bad_specs_name_the_file_and_the_problem(tmp_path, changes: dict, message: str) -> None:
    path = with_changes(tmp_path, changes)
    with pytest.raises(ValueError, match=message) as error:
        load_phantom(path)
    assert str(path) in str(error.value)


def test_unknown_names_and_missing_files() -> None:
    with pytest.raises(ValueError, match=r"unknown phantom .pig.*default"):
        load_phantom("pig")
    with pytest.raises(ValueError, match="not found"):
        load_phantom("/nonexistent/spec.yaml")


GEL = "{name: gel, echogenicity: 0.5, attenuation_db_cm_mhz: 0.5, impedance_mrayl: 1.55}"
SKIN = GEL.replace("name: gel,", "name: skin, thickness: 0.0,")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("size: [0.100, 0.160, 0.060]", "size: [0.100, -0.160, 0.060]",
         r"block size must be three positive numbers, got \(0\.1, -0\.16, 0\.06\)"),
        ("side: right", "side: up", r"side must be right or left, got 'up'"),
        ("noise_level: 0.2", "noise_level: -0.2", r"noise_level must be >= 0, got -0\.2"),
        ("impedance_mrayl: 1.61", "impedance_mrayl: 0.0",
         r"material 'blood': impedance_mrayl must be positive"),
        (GEL, GEL.replace("echogenicity: 0.5", "echogenicity: -0.5"),
         r"material 'gel': echogenicity and attenuation must be >= 0"),
        (GEL, f"{SKIN}\n  - {GEL}", r"layer 'skin': thickness must be positive"),
    ],
)  # fmt: skip
def test_a_refused_value_in_a_spec_names_the_file_and_the_value(tmp_path, old, new, message):
    """The shipped default spec with one value broken: each rule of the spec's data model
    speaks for itself, through the file that broke it."""
    text = (assets_dir() / "phantoms" / "default.yaml").read_text()
    assert old in text
    path = tmp_path / "edited.yaml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ValueError, match=message) as error:
        load_phantom(path)
    assert str(error.value).startswith(f"{path}: ")
