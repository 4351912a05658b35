#!/usr/bin/env python3
"""What a SciPy user writes for the paper's frictionless case, and how it fails.

solve_ivp with terminal events at w = ±l_g, restarted after each impact with the impact map
applied (Eqs. 4-5). Nothing stops the restart from re-detecting the event it just handled or
from missing the next one, so the ball can leave the cavity; nothing reports it.

Run:  python3 tools/crosscheck/scipy_naive_events.py [GAP_M RATIO T_END [direction]]
      (needs numpy and scipy; not part of CI). Variant 1 (no direction) loops forever on the event
      it just handled; variant 2 (direction) lets the ball escape.
Compare with:  vibrobar run --preset paper --friction none --gap-mm 0.1 --ratio 1.0 --solver exact
"""
import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

M, K, ZETA = 0.644, 9.22e6, 0.01
C = 2 * ZETA * math.sqrt(K * M)
MD, E, F0 = 0.026, 0.5, 15.0
GAP = float(sys.argv[1]) if len(sys.argv) > 1 else 0.1e-3
RATIO = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
LG = GAP / 2
OM = RATIO * math.sqrt(K / M)
MU = MD / M
T_END = float(sys.argv[3]) if len(sys.argv) > 3 else 0.2


def rhs(t, y):
    u, du, v, dv = y
    return [du, (F0 * math.sin(OM * t) - C * du - K * u) / M, dv, 0.0]


def hit_plus(t, y):
    return y[2] - y[0] - LG


def hit_minus(t, y):
    return y[2] - y[0] + LG


hit_plus.terminal = True
hit_minus.terminal = True
# Variant 2 (argv[4] == "direction"): the usual fix for the endless loop of variant 1 is to
# detect only crossings into the wall. Then a crossing that happens and undoes itself inside one
# solver step (grazing) is never seen, and the ball leaves the cavity for good.
if len(sys.argv) > 4 and sys.argv[4] == "direction":
    hit_plus.direction = 1.0
    hit_minus.direction = -1.0

t, y = 0.0, np.zeros(4)
impacts, worst, stalled = 0, 0.0, 0
while t < T_END:
    if impacts >= 20000 or stalled >= 1000:
        print(f"gave up at t = {t:.6f} s after {impacts} 'impacts' ({stalled} restarts in a row without progress): "
              f"the restart keeps re-detecting the event it just handled; max |w| = {worst:.3e} m, l_g = {LG:.3e} m")
        break
    sol = solve_ivp(rhs, (t, T_END), y, events=(hit_plus, hit_minus), rtol=1e-6, atol=1e-12, max_step=1e-4)
    w = sol.y[2] - sol.y[0]
    worst = max(worst, float(np.max(np.abs(w))))
    if worst > 1.5 * LG:
        print(f"ball escaped the cavity: |w| = {worst:.3e} m > l_g = {LG:.3e} m at t ≈ {sol.t[-1]:.5f} s after {impacts} impacts")
        break
    if sol.status != 1:
        print(f"reached t = {sol.t[-1]:.4f} s: {impacts} impacts, max |w| = {worst:.3e} m (l_g = {LG:.3e} m): confined")
        break
    stalled = stalled + 1 if sol.t[-1] - t < 1e-12 else 0
    t = sol.t[-1]
    y = sol.y[:, -1].copy()
    u, du, v, dv = y
    dw = dv - du
    du_p = du + MU * (1 + E) / (1 + MU) * dw
    y[1], y[3] = du_p, du_p - E * dw
    impacts += 1
