"""Shared fixtures of the Python tests: the source tree, and one simulated tracker dataset."""
import pathlib

import pytest

import orbcal

SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def iiwa7():
    return orbcal.load_robot("builtin:iiwa7.yaml")


@pytest.fixture(scope="session")
def tracker(iiwa7):
    """200 samples of the iiwa7 with random DH errors and nothing else, tracker noise 0.05 mm / 0.01 deg."""
    return orbcal.simulate(iiwa7, samples=200, seed=3)
