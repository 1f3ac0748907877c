#!/usr/bin/env python3
"""What does my arm model get wrong? A newcomer's tour of orbcal from Python.

Simulates laser-tracker data of a KUKA iiwa7 whose joint 3 has a hidden cyclic transmission error (a gear
that is not quite round), asks orbcal to diagnose it, prints the verdict and plots the held-out position
error per sample before and after the diagnosed model, against joint 3's angle.

Run from the repository's root after the build:

    PYTHONPATH=build/python python3 examples/diagnose_tracker.py [OUTPUT_FOLDER]

The figure goes to OUTPUT_FOLDER/diagnose_tracker.png (default: the current folder).
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

robot = orbcal.load_robot("builtin:iiwa7.yaml")
print(f"{robot.name}: {robot.dof} joints")

# 200 tracker samples; the true arm has random DH errors and, hidden, a cyclic error on joint 3:
# 0.02 deg sine and cosine terms of the first two harmonics of its angle (SI values: rad).
a = np.radians(0.02)
data, truth = orbcal.simulate(robot, samples=200, seed=4, effects=["cyclic:3"], values=[a, a, -a, a])
print(f"simulated {len(data)} samples (tracker noise 0.05 mm and 0.01 deg, 1 sigma per axis)")

diagnosis = orbcal.diagnose(data, seed=1)
print("verdict:", diagnosis.verdict)
print(diagnosis.sentence)
for effect in diagnosis.selected:
    print(f"  {effect['effect']} on joint(s) {effect['joints']}:",
          ", ".join(f"{p['name']} = {np.degrees(p['value']):+.4f} deg" if p["unit"] == "rad" else f"{p['name']} = {p['value']:+.3g} {p['unit']}"
                    for p in effect["parameters"]))

# Held-out position error per sample (m -> mm at the edge), against the angle of joint 3 (rad -> deg).
before = np.linalg.norm(diagnosis.residual_base, axis=1) * 1e3
after = np.linalg.norm(diagnosis.residual_selected, axis=1) * 1e3
q3_deg = np.degrees(data.q[:, 2])
fig, ax = plt.subplots(figsize=(7, 4))
ax.scatter(q3_deg, before, s=10, label="geometry + registration")
ax.scatter(q3_deg, after, s=10, label="diagnosed model")
ax.set_xlabel("joint 3 angle (deg)")
ax.set_ylabel("held-out position error (mm)")
ax.set_title(f"orbcal diagnose: {diagnosis.verdict}")
ax.legend()
fig.tight_layout()
png = os.path.join(out, "diagnose_tracker.png")
fig.savefig(png, dpi=120)
print("figure:", png)
