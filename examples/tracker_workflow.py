#!/usr/bin/env python3
"""The whole laser-tracker workflow from Python, as a notebook would run it, cell by cell.

  1. data: two days of tracker measurements of a KUKA iiwa7 (simulated here, with the joints 2 and 4
     yielding to their gravity load; with your own files: orbcal.load_measurements("day1.yaml"))
  2. calibrate the geometry with a hold-out, as `orbcal calibrate` does: refused, and why
  3. diagnose: which effect the geometry misses
  4. calibrate again with the effect named: accepted, on held-out configurations
  5. evaluate the model on the other day (its frames refitted), beside the nominal arm's baseline
  6. apply the exported compliance with the gravity torques, and draw the figures (PNG)

Run from the repository's root after the build:

    PYTHONPATH=build/python python3 examples/tracker_workflow.py [OUTPUT_FOLDER]

It writes OUTPUT_FOLDER/tracker_workflow.png (default: the current folder) and OUTPUT_FOLDER/calibration/
(what `orbcal calibrate -o` writes: report.md, model.yaml, the exports).
"""
import os
import sys

try:
    import matplotlib
    import numpy as np
except ImportError as e:
    sys.exit(f"{e}: this example needs Debian's python3-numpy and python3-matplotlib (tools/install-deps.sh); where "
             "another python3 comes first on the PATH (pyenv, conda), run it with /usr/bin/python3")

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))  # no display needed
import matplotlib.pyplot as plt  # noqa: E402

import orbcal  # noqa: E402

out = sys.argv[1] if len(sys.argv) > 1 else "."
os.makedirs(out, exist_ok=True)
print(f"orbcal {orbcal.__version__}")

# %% 1. Data: four sessions, two a day, each day one without and one with a 1.25 kg payload. The true arm has
# random DH errors and compliant joints 2 and 4 (2e-5 and 3e-5 rad per N m: 0.1 mm of sag at the flange);
# the tracker noise is 0.05 mm and 0.01 deg, 1 sigma per axis. Day 2 is put in its own Measurements with
# its own, unknown tracker frames (per_session): the tracker was set up again.
robot = orbcal.load_robot("builtin:iiwa7.yaml")
payloads = [0.0, 1.25, 0.0, 1.25]
data, truth = orbcal.simulate(robot, samples=320, seed=2, sessions=4, payload_kg=payloads, effects=["compliance:2,4"],
                              values=[2e-5, 3e-5])
session = np.asarray(data.session)


def day(sessions):
    rows = np.isin(session, sessions)
    return orbcal.measurements_from_arrays(robot, q=data.q[rows], poses=data.poses[rows], torques=data.torques[rows],
                                           session=list(session[rows] - min(sessions)), noise=data.noise,
                                           base="per_session", marker="per_session")


day1, day2 = day([0, 1]), day([2, 3])
print(f"day 1: {len(day1)} samples, day 2: {len(day2)} samples")

# %% 2. The geometry alone, held-out configurations kept out of the fit: refused, as the command line refuses it
# (exit 1); accept_worse=True would return the model anyway, marked as not accepted.
try:
    orbcal.calibrate(day1)
except orbcal.Refused as refused:
    geometry_only = refused.calibration
    print("geometry only: not accepted:")
    for why in geometry_only.refusals:
        print("  -", why)

# %% 3. What does the geometry miss? The diagnosis tests every cause of the catalog on held-out data.
diagnosis = orbcal.diagnose(day1)
print("diagnosis:", diagnosis.sentence)
effects = [f"{e['effect']}:{','.join(map(str, e['joints']))}" for e in diagnosis.selected]
print("effects named:", effects)

# %% 4. Calibrate with the named effects: the same hold-out, now accepted. The files go where `-o` would put them.
calibration = orbcal.calibrate(day1, effects=effects, out=os.path.join(out, "calibration"))
held = calibration.heldout
print(f"with {', '.join(effects)}: accepted={calibration.accepted}; held-out position RMS "
      f"{held['before']['position_rms_m'] * 1e3:.4f} mm (nominal arm) -> {held['after']['position_rms_m'] * 1e3:.4f} mm "
      f"({held['configurations']} configurations, p = {held['p_value']:.2g}); report: {calibration.report_path}")
model = calibration.model
records = model.to_records()  # one dict per parameter: pandas.DataFrame(records) where pandas is installed
for r in records:
    if r["effect"] == "compliance":
        print(f"  {r['name']} = {r['value']:.3g} +- {r['sigma']:.2g} {r['unit']} (stiffness {1 / r['value']:.3g} N m/rad)")

# %% 5. The other day: every parameter is the model's, only day 2's tracker and marker frames are refitted.
evaluation = orbcal.evaluate(model, day2)
print(f"day 2: calibrated {evaluation['position_rms_m'] * 1e3:.4f} mm, baseline (nominal arm, frames fitted) "
      f"{evaluation['baseline']['position_rms_m'] * 1e3:.4f} mm position RMS")

# %% 6. The compliance applied as effects.yaml states it (docs/export.md): joint N stands at its reading plus
# dqN = -(cN * tauN), tauN the gravity torque the actuator holds (Robot.gravity_torques, N m).
compliance = {r["name"]: r["value"] for r in records if r["effect"] == "compliance"}
q2 = day2.q
tau = np.concatenate([robot.gravity_torques(q2[np.asarray(day2.session) == s], payload_kg=payloads[s + 2])
                      for s in range(day2.sessions)])
q2 = np.concatenate([q2[np.asarray(day2.session) == s] for s in range(day2.sessions)])
sag_deg = {j: np.degrees(-compliance[f"c{j}"] * tau[:, j - 1]) for j in (2, 4)}
flange = robot.fk(q2)  # N x 4 x 4 at once
print(f"flange positions of day 2: {flange.shape[0]} poses; largest sag: joint 2 {np.abs(sag_deg[2]).max():.4f} deg, "
      f"joint 4 {np.abs(sag_deg[4]).max():.4f} deg")

fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
ax = axes[0]
torque2 = day1.torques[:, 1]
ax.scatter(torque2, np.linalg.norm(diagnosis.residual_base, axis=1) * 1e3, s=8, label="geometry + registration")
ax.scatter(torque2, np.linalg.norm(diagnosis.residual_selected, axis=1) * 1e3, s=8, label="with " + ", ".join(effects))
ax.set_xlabel("joint 2 torque (N m)")
ax.set_ylabel("held-out position error (mm)")
ax.set_title("3. diagnosis (day 1, cross-validated)")
ax.legend(fontsize=8)
ax = axes[1]
names = ["nominal arm\nday 1, held out", "calibrated\nday 1, held out", "nominal arm\nday 2 (baseline)", "calibrated\nday 2"]
values = [held["before"]["position_rms_m"], held["after"]["position_rms_m"], evaluation["baseline"]["position_rms_m"],
          evaluation["position_rms_m"]]
ax.bar(names, np.array(values) * 1e3, color=["C0", "C1", "C0", "C1"])
ax.axhline(np.sqrt(3) * 0.05, color="k", ls="--", lw=1, label="noise alone (sqrt(3) x 0.05 mm)")
ax.set_ylabel("position RMS (mm)")
ax.set_yscale("log")
ax.set_ylim(0.5 * min(values) * 1e3, 8 * max(values) * 1e3)  # room for the legend above the bars
ax.tick_params(axis="x", labelsize=8)
ax.set_title("4.-5. held out and the other day")
ax.legend(fontsize=8)
ax = axes[2]
for j in (2, 4):
    ax.scatter(tau[:, j - 1], sag_deg[j], s=8, label=f"joint {j}")
ax.set_xlabel("gravity torque (N m)")
ax.set_ylabel("deflection -c tau (deg)")
ax.set_title("6. the compliance applied (day 2)")
ax.legend(fontsize=8)
fig.tight_layout()
png = os.path.join(out, "tracker_workflow.png")
fig.savefig(png, dpi=110)
print("figure:", png)
