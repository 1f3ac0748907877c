"""orbcal.diagnose names a hidden effect on the joint it was put on, and its JSON is diagnosis.json."""
import json

import numpy as np
import pytest

import orbcal


def test_diagnose_names_a_hidden_cyclic_error_on_its_joint(iiwa7):
    # The joint is drawn (seeded), so the test does not lean on one joint's geometry.
    joint = int(np.random.default_rng(2024).integers(1, 8))
    # 0.02 deg per coefficient: twice the catalog's typical magnitude, the largest orbcal diagnose-study draws
    # (0.5 to 2 times): the test asks for a detection, not for the detector's limit.
    amplitude = np.radians(0.02)
    data, truth = orbcal.simulate(iiwa7, samples=200, seed=21, effects=[f"cyclic:{joint}"],
                                  values=[amplitude, -amplitude, amplitude, amplitude])
    d = orbcal.diagnose(data, seed=1)
    assert d.verdict == "effects", d.sentence
    named = [(s["effect"], s["joints"]) for s in d.selected]
    assert ("cyclic", [joint]) in named, (joint, named, d.sentence)
    cyclic = next(s for s in d.selected if s["effect"] == "cyclic")
    assert {p["unit"] for p in cyclic["parameters"]} == {"rad"}
    # The JSON is orbcal diagnose's diagnosis.json: the same keys and the same selection.
    doc = json.loads(d.to_json())
    assert doc["verdict"] == d.verdict and doc["selected"] == d.selected and doc["confounded"] == d.confounded
    assert {"noise", "heldout", "lack_of_fit", "unexplained"} <= doc.keys()
    # Held-out residuals for figures: per sample, in metres; the selected model's are smaller.
    assert d.residual_base.shape == d.residual_selected.shape == (200, 3)
    rms = lambda r: float(np.sqrt(np.mean(np.sum(r ** 2, axis=1))))  # noqa: E731
    assert rms(d.residual_selected) == pytest.approx(d.heldout["selected"]["position_rms_m"], rel=1e-9)
    assert d.heldout["selected"]["position_rms_m"] < d.heldout["base"]["position_rms_m"]
    assert any(n.startswith("cyclic") for n in d.model.parameter_names)


def test_diagnose_of_clean_data_is_clean(tracker):
    data, _ = tracker
    calls = []
    d = orbcal.diagnose(data, seed=1, progress=lambda done, total: calls.append((done, total)))
    assert d.verdict == "clean", d.sentence
    assert d.selected == [] and d.confounded == []
    # Its phases, as orbcal diagnose's progress line shows them: each once, in order, then the end.
    n = len(orbcal.diagnose_phases)
    assert n == 6 and "forward selection" in orbcal.diagnose_phases
    assert calls == [(k, n) for k in range(n + 1)]


def test_an_exception_of_the_progress_callable_stops_the_diagnosis(tracker):
    data, _ = tracker

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        orbcal.diagnose(data, seed=1, progress=stop)


def test_diagnose_estimates_the_noise_on_a_subset_as_asked(tracker):
    # The tracker fixture does not state the joint readings' noise, so it is estimated: on every
    # observation by default (fewer than 20,000 here); asked for 60, on a seeded random subset of them,
    # enlarged to what the flexible model needs, which diagnosis.json's noise_floor says.
    data, _ = tracker
    whole = orbcal.diagnose(data, seed=1)
    part = orbcal.diagnose(data, seed=1, noise_observations=60)
    assert whole.as_dict()["noise_floor"]["noise_observations"] == 0
    assert 60 < part.as_dict()["noise_floor"]["noise_observations"] < len(data)
    assert part.verdict == whole.verdict == "clean", part.sentence
    with pytest.raises(ValueError, match="noise_observations"):
        orbcal.diagnose(data, noise_observations=-1)


def test_diagnose_selects_on_a_subset_as_asked(tracker):
    # Asked for a selection on 80 observations, diagnose selects on a seeded random 80 of them and says
    # so in diagnosis.json; the selected model's held-out residuals are still every observation's.
    data, _ = tracker
    whole = orbcal.diagnose(data, seed=1)
    part = orbcal.diagnose(data, seed=1, selection_observations=80)
    assert whole.as_dict()["selection_observations"] == 0
    assert part.as_dict()["selection_observations"] == 80
    assert part.residual_selected.shape == (len(data), 3)
    assert part.verdict == whole.verdict == "clean", part.sentence
    with pytest.raises(ValueError, match="selection_observations"):
        orbcal.diagnose(data, selection_observations=-1)
