"""The compiled step of a LoopBatch (cosim.control.loop_batch): every row's closed loop
advanced (`advance_core`), then what `ClosedLoop.record` reads into the row's outputs."""

from __future__ import annotations

from typing import Any

from cosim.compiled import Array, njit
from cosim.vehicle.bicycle import bicycle_fa, bicycle_lateral_forces
from cosim.vehicle.twotrack import twotrack_derivative

from .closed_loop import CS_S_ROAD, OK, advance_core
from .reference import frame_path_errors

# the outputs' row: the plant's pose and speeds, its accelerations, the path errors at
# the step's end, the inputs held, the car's pose to the road, the step's status
O_X, O_Y, O_PSI, O_VX, O_VY, O_R, O_AX, O_AY = 0, 1, 2, 3, 4, 5, 6, 7
O_XREF, O_YREF, O_VXREF, O_KAPPA, O_YE, O_PHIE, O_EX, O_ALONG = 8, 9, 10, 11, 12, 13, 14, 15
O_DELTA, O_DMZ, O_FA, O_FX = 16, 17, 18, 19  # O_FX: four wheel forces FL, FR, RL, RR
O_S, O_D, O_REL = 23, 24, 25  # m, m, rad: the car's centre to the road frame
O_STATUS, O_SAT = 26, 27  # closed_loop's OK / BAD_CONTROL / BAD_STATE; saturated 0 / 1
OUT_SIZE = 28


@njit
def advance_batch(kind: int, rows: Any, s: Array, pconst: Array, pinputs: Array,
                  pforces: Array, coef: Array, fp: Array, fr: Array, lp: Array, cp: Array,
                  ff: Array, cs: Array, counters: Any, out: Array, scratch: Array, t: float,
                  t_end: float, h: float, substeps: int, control_every: int) -> int:
    """`advance_core` from t for each row in `rows` (kind 0 two-track, 1 bicycle), then
    `ClosedLoop.record`'s numbers at t_end into `out`. Returns -1, or the position in
    `rows` of the first row whose step failed (its status in out[.., O_STATUS]; the rows
    after it are not advanced)."""
    for j in range(rows.size):
        i = rows[j]
        si, ci, o = s[i], cs[i], out[i]
        status, counter, saturated = advance_core(
            kind, si, pconst[i], pinputs[i], pforces[i], coef[i], fp, fr, lp[i], cp[i],
            ff[i], ci, t, h, substeps, control_every, counters[i])
        counters[i] = counter
        o[O_STATUS] = status
        o[O_SAT] = 1.0 if saturated else 0.0
        if status != OK:
            return j
        # ClosedLoop.errors
        e = frame_path_errors(coef[i], fp, fr, t_end, si[0], si[1], si[2], si[3], si[4],
                              si[5], ci[0], ci[CS_S_ROAD])
        ci[0] = e[5]
        ci[CS_S_ROAD] = e[11]
        # the plant's outputs (TwoTrackPlant.outputs, BicyclePlant.outputs)
        if kind == 0:
            twotrack_derivative(si, pconst[i], pinputs[i], pforces[i], scratch)
            ax, ay = pforces[i, 0], pforces[i, 1]
            f1, f2, f3, f4 = pforces[i, 2], pforces[i, 3], pforces[i, 4], pforces[i, 5]
        else:
            c, u = pconst[i], pinputs[i]
            vx = si[3]
            fyf, fyr = bicycle_lateral_forces(si, c, u)
            fa = bicycle_fa(si, c, u)
            ax, ay = (fa - c[6] * vx * abs(vx)) / c[0], (fyf + fyr) / c[0]
            f1, f2, f3, f4 = u[3], u[4], u[5], u[6]
        o[O_X], o[O_Y], o[O_PSI], o[O_VX], o[O_VY], o[O_R] = si[0], si[1], si[2], si[3], \
            si[4], si[5]
        o[O_AX], o[O_AY] = ax, ay
        o[O_XREF], o[O_YREF], o[O_VXREF], o[O_KAPPA] = e[8], e[9], e[6], e[4]
        o[O_YE], o[O_PHIE], o[O_EX], o[O_ALONG] = e[0], e[1], si[3] - e[6], e[10]
        o[O_DELTA], o[O_DMZ], o[O_FA] = ci[3], ci[4], ci[5]
        o[O_FX], o[O_FX + 1], o[O_FX + 2], o[O_FX + 3] = f1, f2, f3, f4
        o[O_S], o[O_D], o[O_REL] = e[11], e[12], e[13]
    return -1
