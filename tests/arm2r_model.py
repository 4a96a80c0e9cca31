"""The 2R arm of mjbench/scenarios/arm2r.toml in closed form (textbook formulas, written here from the
scenario's numbers: the independent path of tests/test_multi_axis.py and tests/test_multi_gear.py)."""
from __future__ import annotations

import math

import numpy as np

# the 2R arm of mjbench/scenarios/arm2r.toml: upper 1.2 kg, 0.30 m, centre 0.15 m, 9e-3 kg·m²;
# forearm 0.8 kg + 0.2 kg at the tip T (0.25 m), centre 0.125 m, 4.2e-3 kg·m²
M1, L1, C1, I1 = 1.2, 0.30, 0.15, 9.0e-3
M2B, L2, C2B, I2B, MT = 0.8, 0.25, 0.125, 4.2e-3, 0.2
M2 = M2B + MT
C2 = (M2B * C2B + MT * L2) / M2
I2 = I2B + M2B * (C2B - C2) ** 2 + MT * (L2 - C2) ** 2
G = 9.81


def arm_closed_form(q1, q2, qd1, qd2):
    """M(q), c(q, q̇), g(q) of a planar 2R arm in relative coordinates (q2: elbow), gravity −y."""
    a1 = I1 + M1 * C1 ** 2 + M2 * L1 ** 2
    a2 = I2 + M2 * C2 ** 2
    b = M2 * L1 * C2
    c2, s2 = math.cos(q2), math.sin(q2)
    Mq = np.array([[a1 + a2 + 2 * b * c2, a2 + b * c2], [a2 + b * c2, a2]])
    c = np.array([-b * s2 * (2 * qd1 * qd2 + qd2 ** 2), b * s2 * qd1 ** 2])
    g = G * np.array([(M1 * C1 + M2 * L1) * math.cos(q1) + M2 * C2 * math.cos(q1 + q2), M2 * C2 * math.cos(q1 + q2)])
    return Mq, c, g


def arm_energy(q, qd, J=0.0):
    """½q̇ᵀ(M(q) + J·1)q̇ + E_p(q) of the arm at joint angles q and rates q̇ (J: a drive inertia on each joint)."""
    Mq = arm_closed_form(q[0], q[1], 0.0, 0.0)[0] + J * np.eye(2)
    Ep = G * ((M1 * C1 + M2 * L1) * math.sin(q[0]) + M2 * C2 * math.sin(q[0] + q[1]))
    return 0.5 * qd @ Mq @ qd + Ep
