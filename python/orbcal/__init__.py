"""orbcal from Python: robots, measured data, calibration, diagnosis, rendering and studies.

SI units throughout (m, rad, N m, degC, s); numpy arrays in and out. Bad input raises orbcal.Error (a
RuntimeError) carrying orbcal's one-line message, which names the file and the key.

    import orbcal
    robot = orbcal.load_robot("builtin:iiwa7.yaml")
    data, truth = orbcal.simulate(robot, samples=200, effects=["compliance:2"])
    diagnosis = orbcal.diagnose(data)
    print(diagnosis.verdict, diagnosis.selected)
"""
from ._orbcal import (Diagnosis, Error, Measurements, Model, Robot, calibrate, diagnose, evaluate,  # noqa: F401
                      load_measurements, load_model, load_robot, measurements_from_arrays, render_dataset,
                      run_study, simulate, version)

__all__ = ["Diagnosis", "Error", "Measurements", "Model", "Robot", "calibrate", "diagnose", "evaluate",
           "load_measurements", "load_model", "load_robot", "measurements_from_arrays", "render_dataset",
           "run_study", "simulate", "version"]
