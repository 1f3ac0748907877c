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
    stages = []
    r = orbcal.run_study(str(study), str(tmp_path / "study"), jobs=2, progress=lambda *a: stages.append(a))
    assert r["tasks"] == 2 and r["ran"] == 2
    assert sorted(p.name for p in (tmp_path / "study" / "shards").iterdir()) == ["task-000000", "task-000001"]
    assert len(list((tmp_path / "study" / "shards").rglob("*.png"))) == 4  # two datasets of two images
    assert pathlib.Path(r["report"]).is_file()
    assert ("study tasks", 2, 2) in stages
    again = orbcal.run_study(str(study), str(tmp_path / "study"), jobs=2)
    assert again["ran"] == 0  # resumed: nothing left to run


def test_run_study_refuses_a_bad_study_file(tmp_path):
    study = tmp_path / "bad.yaml"
    study.write_text("format: orbcal-study-1\njob: paint\nseeds: [1]\n")
    with pytest.raises(orbcal.Error) as e:
        orbcal.run_study(str(study), str(tmp_path / "bad"))
    assert str(e.value).startswith(f"{study}: job: expected experiment")
    assert not (tmp_path / "bad").exists()


def test_run_study_names_a_failed_task_and_merges_nothing(tmp_path):
    study = tmp_path / "fails.yaml"
    study.write_text("format: orbcal-study-1\njob: render\noptions: {count: 2, colour: red}\nseeds: [1]\n")
    with pytest.raises(orbcal.Error) as e:
        orbcal.run_study(str(study), str(tmp_path / "f"))
    message = str(e.value)
    assert "\n" not in message and message.startswith("1 of 1 tasks failed, the first: task 0: exit status")
    log = tmp_path / "f" / "shards" / "task-000000.failed" / "log.txt"
    assert str(log) in message and "colour" in log.read_text()
    assert not (tmp_path / "f" / "merged").exists()
