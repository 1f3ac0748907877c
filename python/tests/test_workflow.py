"""orbcal.render_dataset and orbcal.run_study: a small rendered dataset and a small study, and their refusals."""
import pathlib

import pytest

import orbcal


def test_render_dataset_writes_images_and_a_manifest(tmp_path):
    out = tmp_path / "ds"
    calls = []
    report = orbcal.render_dataset("builtin:default_scene.yaml", 3, str(out), errors="table3", seed=2,
                                   progress=lambda done, total: calls.append((done, total)))
    assert report["rendered"] == 3 and report["skipped"] == 0
    assert len(list(out.rglob("*.png"))) == 3
    assert any(out.glob("manifest.*"))
    assert calls and calls[-1] == (3, 3)
    again = orbcal.render_dataset("builtin:default_scene.yaml", 3, str(out), errors="table3", seed=2)
    assert again["rendered"] == 0 and again["skipped"] == 3 and again["resumed"]


def test_render_dataset_refuses_a_missing_scene_and_leaves_nothing(tmp_path):
    with pytest.raises(orbcal.Error, match="no-such-scene.yaml: cannot read"):
        orbcal.render_dataset(str(tmp_path / "no-such-scene.yaml"), 2, str(tmp_path / "ds"))
    assert not any((tmp_path / "ds").rglob("*.png"))


def test_run_study_runs_every_task_and_merges(tmp_path):
    study = tmp_path / "s.yaml"
    study.write_text("format: orbcal-study-1\njob: render\noptions: {count: 2}\nseeds: [1, 2]\n")
    r = orbcal.run_study(study, tmp_path / "study", jobs=2)
    assert sorted(p.name for p in (tmp_path / "study" / "shards").iterdir()) == ["task-000000", "task-000001"]
    assert pathlib.Path(r["report"]).is_file()


def test_run_study_refuses_an_unknown_option(tmp_path):
    study = tmp_path / "bad.yaml"
    study.write_text("format: orbcal-study-1\njob: render\noptions: {colour: red}\nseeds: [1]\n")
    with pytest.raises(orbcal.Error) as e:
        orbcal.run_study(study, tmp_path / "bad")
    assert str(e.value) == f"{study}: options.colour: not an option of orbcal render (see orbcal render --help)"
    assert not (tmp_path / "bad").exists()
