"""Training units: what their key holds, so a cached run is reused only for the same inputs."""

from __future__ import annotations

from resus.execution.units import as_json
from resus.experiments.training_units import TrainingUnit
from resus.segmentation.presets import QUICK


def imagenet_unit(cache, weights) -> TrainingUnit:
    return TrainingUnit("subjects", "imagenet", "default/0", 0, (), (), QUICK, "cpu", 1, cache,
                        weights)  # fmt: skip


def test_encoder_weights_count_by_content_not_only_by_name(tmp_path):
    weights = tmp_path / "encoder.pth"
    weights.write_bytes(b"one set of weights")
    first = imagenet_unit(tmp_path, weights)
    assert imagenet_unit(tmp_path, weights).key() == first.key()  # the same run
    assert first.key()["encoder_weights"]["name"] == "encoder.pth"
    weights.write_bytes(b"another set of weights, same name")
    replaced = imagenet_unit(tmp_path, weights)
    assert replaced.key() != first.key() and replaced.folder != first.folder
    assert first.record().key == as_json(first.key())  # a unit keeps the file it was made with
