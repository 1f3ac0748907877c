"""orbcal from Python: robots, measured data, calibration, diagnosis, rendering and studies.

SI units throughout (m, rad, N m, degC, s); numpy arrays in and out. Bad input raises orbcal.Error (a
RuntimeError) carrying orbcal's one-line message, which names the file and the key.

    import orbcal
    robot = orbcal.load_robot("builtin:iiwa7.yaml")
    data, truth = orbcal.simulate(robot, samples=200, effects=["compliance:2"])
    diagnosis = orbcal.diagnose(data)
    print(diagnosis.verdict, diagnosis.selected)
"""
import os
import subprocess

from ._orbcal import (Diagnosis, Error, Measurements, Model, Robot, calibrate, diagnose, evaluate,  # noqa: F401
                      load_measurements, load_model, load_robot, measurements_from_arrays, render_dataset,
                      simulate, version)
from ._program import PROGRAM

__all__ = ["Diagnosis", "Error", "Measurements", "Model", "Robot", "calibrate", "diagnose", "evaluate",
           "load_measurements", "load_model", "load_robot", "measurements_from_arrays", "render_dataset",
           "run_study", "simulate", "version"]


def run_study(study_file, out, jobs=None, merge=True, plots=False, quiet=True):
    """Runs every task of a study file here, as `orbcal study run STUDY -o OUT` does (the study engine runs each
    task as the `orbcal` program built beside this module), `jobs` at once (default: every core this process may
    use), then merges them into OUT/merged unless merge=False (figures only with plots=True). A rerun resumes:
    only missing and failed tasks run. Returns {"folder", "merged", "report"} (paths; merged and report None
    without a merge). Raises orbcal.Error with orbcal's message when the study is refused or a task fails."""
    args = [PROGRAM, "study", "run", os.fspath(study_file), "-o", os.fspath(out)]
    if jobs is not None:
        args += ["-j", str(int(jobs))]
    if not merge:
        args.append("--no-merge")
    if not plots:
        args.append("--no-plots")
    result = subprocess.run(args, capture_output=True, text=True)
    if not quiet:
        print(result.stdout, end="")
    if result.returncode != 0:
        lines = [line for line in result.stderr.splitlines() if line.startswith("orbcal: ")]
        raise Error(lines[-1][len("orbcal: "):] if lines else f"orbcal study run exited with status {result.returncode}")
    merged = os.path.join(os.fspath(out), "merged") if merge else None
    return {"folder": os.fspath(out), "merged": merged, "report": os.path.join(merged, "report.md") if merge else None}
