"""orbcal from Python: robots, measured data, calibration, diagnosis, rendering, twins of real
images and studies.

SI units throughout (m, rad, N m, degC, s); numpy arrays in and out. Bad input raises orbcal.Error (a
RuntimeError) carrying orbcal's one-line message, which names the file and the key; a calibration that
`orbcal calibrate` refuses raises orbcal.Refused (an orbcal.Error whose .calibration says why).

    import orbcal
    robot = orbcal.load_robot("builtin:iiwa7.yaml")
    data, truth = orbcal.simulate(robot, samples=200, effects=["compliance:2"])
    diagnosis = orbcal.diagnose(data)
    print(diagnosis.verdict, diagnosis.selected)
    calibration = orbcal.calibrate(data, effects=["compliance:2"])
    print(calibration.accepted, calibration.heldout["after"]["position_rms_m"])
"""
from ._orbcal import (Calibration, Diagnosis, Error, Measurements, Model, Refused, Robot, __version__,  # noqa: F401
                      calibrate, calibrate_images, diagnose, diagnose_phases, evaluate, load_measurements, load_model,
                      load_robot, measurements_from_arrays, render_dataset, run_study, simulate, twin, version)

__all__ = ["Calibration", "Diagnosis", "Error", "Measurements", "Model", "Refused", "Robot", "__version__", "calibrate",
           "calibrate_images", "diagnose", "diagnose_phases", "evaluate", "load_measurements", "load_model",
           "load_robot", "measurements_from_arrays", "render_dataset", "run_study", "simulate", "twin", "version"]
