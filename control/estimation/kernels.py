"""The EKF's per-step arithmetic, compiled: prediction, fix update and the replay after a delayed fix.

:class:`control.estimation.ekf.PoseEstimator` keeps its state in preallocated arrays (a ring buffer
of states, covariances, times and inputs, and scratch, in one block) and calls these
kernels once per control period and once per fix; they work in place and allocate nothing per
prediction, so a period costs one call into compiled code instead of a few dozen small numpy
operations. The equations are the module doc's of :mod:`control.estimation.ekf`, written out
element by element in the same order of operations (matrix products are summed in index order, so
results can differ from numpy's BLAS products only at round-off, and are the same bit for bit from
run to run).

Errors are returned as a status code (:data:`OK`, :data:`BAD_INCREMENT`, :data:`BAD_STATE`,
:data:`BAD_INNOVATION`) with the time they happened at, and raised by the caller, which words
the message.

All of a filter's arrays live in one float block of rows of :data:`N` (the state's size, 10;
:func:`allocate`), so that a call into compiled code passes one array (a call's cost grows with its
arguments, and a period makes few calls) and every part is a slice of rows (no reshaping per call).
By row:

- 0-1: the filter's constants, flat, indexed by :data:`RADIUS` .. :data:`REJECT` (:func:`parameters`);
- from :data:`F_ROW`, N rows: the Jacobian F of the last prediction (identity but where
  :func:`propagate` writes); from :data:`Q_ROW`, N rows: its noise Q (zero likewise); from
  :data:`TMP_ROW`, N rows: a product;
- :data:`X_ROW`, then N rows from :data:`P_ROW`: a replay's state and its covariance; :data:`NU_ROW`:
  the innovation of the last gated fix (columns 0-2), then the ring's newest step, its number of
  steps, the newest time [s] and the distance driven [m] (columns :data:`HEAD`, :data:`SIZE`,
  :data:`TIME`, :data:`ODO`; the head is -1 before a reset);
- from :data:`RING`, the ring of the last C steps: C rows (time [s], left and right wheel
  increments [rad], gyro rate [rad/s]), C rows of states, C blocks of N rows of covariances.

:class:`Block` gives the same parts as numpy views, for the Python side.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from control.estimation.odometry import sinc_half
from planning.core.copy_kernels import copy_into, copy_rows_into
from planning.curves.common import mod2pi

FloatArray = NDArray[np.float64]


#: Indices into the parameter array.
RADIUS, TRACK, WHEEL_VAR, POSITION_VAR, GYRO_VAR, BIAS_WALK_VAR, QUANT_VAR, GYRO, GATE, REJECT = range(10)
N_PARAMS = 10
#: Status codes.
OK, BAD_INCREMENT, BAD_STATE, BAD_INNOVATION, BAD_TIME, BAD_READING = range(6)

N = 10  # state size (control.estimation.ekf.N_STATE)
#: The range sensor's scale and offset errors in the state (control.estimation.ekf.IRS, IRO).
IRS, IRO = 8, 9
#: Columns of a fix: t_meas, z (3), from NOISE its noise covariance R (xx, xy, xtheta, yy, ytheta,
#: thetatheta), then from GAIN its (3, 2) gain G row by row.
NOISE = 4
GAIN = NOISE + 6
FIX_COLS = GAIN + 6
#: First rows of the block's parts (see the module doc) and rows per ring step.
F_ROW, Q_ROW, TMP_ROW, X_ROW, P_ROW, NU_ROW, RING = 2, 2 + N, 2 + 2 * N, 2 + 3 * N, 3 + 3 * N, 3 + 4 * N, 4 + 4 * N
STEP_ROWS = 2 + N
#: Columns of row NU_ROW holding the ring's bookkeeping: newest step, number of steps, newest time [s],
#: and the distance the wheels' mean turn has driven since the reset [m] (|r (dl + dr) / 2| summed).
HEAD, SIZE, TIME, ODO = 3, 4, 5, 6


def parameters(
    radius: float,
    track: float,
    wheel_var: float,
    position_var: float,
    gyro_var: float,
    bias_walk_var: float,
    quant_var: float,
    gyro: bool,
    gate: float,
    reject: bool,
) -> FloatArray:
    """The (N_PARAMS,) parameter array of a filter.

    Args:
        radius: Nominal wheel radius r [m].
        track: Nominal track width b [m].
        wheel_var: Wheel-angle noise variance per radian turned [rad].
        position_var: Position noise variance per metre driven [m].
        gyro_var: Gyro white-noise density squared [rad^2/s] (0 with the encoder heading).
        bias_walk_var: Gyro bias walk variance per second [rad^2/s^3] (0 with the encoder heading).
        quant_var: Encoder quantisation variance per second [rad^2/s] (:data:`control.estimation.ekf.QUANT_PERIOD`).
        gyro: The heading increment comes from the gyro (else from the encoders).
        gate: NIS above which a fix is an outlier.
        reject: Outlier fixes are not applied.
    """
    return np.array(
        [radius, track, wheel_var, position_var, gyro_var, bias_walk_var, quant_var, float(gyro), gate, float(reject)]
    )


def allocate(steps: int) -> FloatArray:
    """A zeroed block for a ring of ``steps`` steps (see the module doc), F set to the identity."""
    mem = np.zeros((RING + steps * STEP_ROWS, N))
    mem[F_ROW : F_ROW + N] = np.eye(N)
    mem[NU_ROW, HEAD], mem[NU_ROW, TIME] = -1.0, math.nan
    return mem


class Block(NamedTuple):
    """Numpy views of a block's parts (see the module doc).

    Attributes:
        prm: (N_PARAMS,) constants. f, q, tmp: (N, N) F, Q, scratch. nu: (3,) last gated innovation.
        bt: (C,) step times [s]. bu: (C, 3) step inputs. bx: (C, N) states. bP: (C, N, N) covariances.
    """

    prm: FloatArray
    f: FloatArray
    q: FloatArray
    tmp: FloatArray
    nu: FloatArray
    bt: FloatArray
    bu: FloatArray
    bx: FloatArray
    bP: FloatArray

    @classmethod
    def of(cls, mem: FloatArray) -> Block:
        """The views of ``mem`` (made by :func:`allocate`)."""
        cap = (mem.shape[0] - RING) // STEP_ROWS
        ring, states, covs = mem[RING : RING + cap], mem[RING + cap : RING + 2 * cap], mem[RING + 2 * cap :]
        return cls(
            mem[:2].reshape(-1)[:N_PARAMS], mem[F_ROW:Q_ROW], mem[Q_ROW:TMP_ROW], mem[TMP_ROW:X_ROW],
            mem[NU_ROW, :3], ring[:, 0], ring[:, 1:4], states, covs.reshape(cap, N, N),
        )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _ring(mem: FloatArray) -> tuple[int, int]:  # pragma: no cover - compiled
    """(first row of the ring's states, first row of its covariances)."""
    cap = (mem.shape[0] - RING) // STEP_ROWS
    return RING + cap, RING + 2 * cap


#: ``math.remainder(a, 2 pi)`` (but for exact ties at +-pi, which keep their sign) [rad]: the curves'
#: angle wrap, compiled inline where it is called.
wrap = mod2pi


@nb.njit(cache=True)
def _congruence(p: FloatArray, f: FloatArray, q: FloatArray, tmp: FloatArray) -> None:  # pragma: no cover - compiled
    """p = f p f^T + q in place (all (N, N); tmp is scratch).

    f is the identity but in rows 0-2, columns 2 to N - 1 (above the diagonal): its other rows copy, and
    its identity entries add each term once, in the order a full product sums them (the same
    result, bit for bit, with a third of the multiplications).
    """
    copy_rows_into(tmp, p)
    for i in range(3):  # tmp = f p
        for k in range(N):
            s = p[i, k]
            for j in range(max(2, i + 1), N):
                s += f[i, j] * p[j, k]
            tmp[i, k] = s
    for i in range(N):  # p = tmp f^T + q
        for k in range(N):
            s = tmp[i, k]
            if k < 3:
                for j in range(max(2, k + 1), N):
                    s += tmp[i, j] * f[k, j]
            p[i, k] = s + q[i, k]


@nb.njit(cache=True)
def propagate(
    x: FloatArray,
    p: FloatArray,
    f: FloatArray,
    q: FloatArray,
    tmp: FloatArray,
    prm: FloatArray,
    dl: float,
    dr: float,
    w: float,
    dt: float,
) -> int:  # pragma: no cover - compiled
    """One prediction over dt [s] with wheel increments (dl, dr) [rad] and gyro rate w [rad/s], in place.

    The encoders' quantisation variance is a density, per second (see ``quant_var`` of
    :func:`parameters`). Only the non-zero entries of the Jacobian ``f`` (N, N) and the
    noise ``q`` (N, N) are written (the rest stay as set up: f identity, q zero); ``tmp`` (N, N) is
    scratch.

    The motion's direction is the chord's, turned by the cornering slip angle ``-k v omega`` (k the
    state's last component, v = ds / dt, omega = dth / dt; :mod:`control.estimation.ekf`): the
    position's derivatives by ds and dth (``j0s`` .. ``j1t``) include the angle's, so F and Q do.

    Returns:
        OK; BAD_INCREMENT (nothing changed) or BAD_STATE (x and p written) when non-finite.
    """
    r = prm[RADIUS]
    px, py, th, bg, em, ed, be = x[0], x[1], x[2], x[3], x[4], x[5], x[6]
    rl, rr = r * (1.0 + em - ed), r * (1.0 + em + ed)
    ds = 0.5 * (rl * dl + rr * dr)
    vl = prm[WHEEL_VAR] * abs(dl) + dt * prm[QUANT_VAR]
    vr = prm[WHEEL_VAR] * abs(dr) + dt * prm[QUANT_VAR]
    gyro = prm[GYRO] != 0.0
    bb = prm[TRACK] * (1.0 + be)
    if gyro:
        dth = (w - bg) * dt
        s_st, s_tt = 0.0, prm[GYRO_VAR] * dt  # the wheels do not enter dth
    else:
        dth = (rr * dr - rl * dl) / bb
        s_st = 0.5 * (rr * rr * vr - rl * rl * vl) / bb
        s_tt = (rl * rl * vl + rr * rr * vr) / (bb * bb)
    if not math.isfinite(ds + dth):
        return BAD_INCREMENT
    s_ss = 0.25 * (rl * rl * vl + rr * rr * vr)
    c, dc = sinc_half(dth)
    g = -1.0 / (dt * dt) if dt > 0.0 else 0.0  # slip angle = k g ds dth = -k v omega
    ks = x[7] * g  # d(slip angle) / d(ds dth)
    phi = th + 0.5 * dth + ks * ds * dth
    cp, sp = math.cos(phi), math.sin(phi)
    a = ds * c
    j0s, j0t = c * cp - a * sp * ks * dth, ds * (dc * cp - 0.5 * c * sp) - a * sp * ks * ds
    j1s, j1t = c * sp + a * cp * ks * dth, ds * (dc * sp + 0.5 * c * cp) + a * cp * ks * ds
    xn, yn = px + a * cp, py + a * sp
    x[0], x[1], x[2] = xn, yn, wrap(th + dth)
    f[0, 2], f[1, 2] = -a * sp, a * cp
    f[0, 7], f[1, 7] = -a * sp * g * ds * dth, a * cp * g * ds * dth
    s_em, s_ed = 0.5 * r * (dl + dr), 0.5 * r * (dr - dl)  # d ds / d(e_m, e_d)
    if gyro:  # d dth / d b_g = -dt; e_m, e_d act through ds only
        f[0, 3], f[1, 3], f[2, 3] = -j0t * dt, -j1t * dt, -dt
        f[0, 4], f[1, 4], f[0, 5], f[1, 5] = j0s * s_em, j1s * s_em, j0s * s_ed, j1s * s_ed
    else:  # dth depends on e_m, e_d and beta
        t_em, t_ed, t_be = r * (dr - dl) / bb, r * (dr + dl) / bb, -dth / (1.0 + be)
        f[0, 4], f[1, 4], f[2, 4] = j0s * s_em + j0t * t_em, j1s * s_em + j1t * t_em, t_em
        f[0, 5], f[1, 5], f[2, 5] = j0s * s_ed + j0t * t_ed, j1s * s_ed + j1t * t_ed, t_ed
        f[0, 6], f[1, 6], f[2, 6] = j0t * t_be, j1t * t_be, t_be
    pn = prm[POSITION_VAR] * abs(ds)
    q[0, 0] = j0s * j0s * s_ss + 2.0 * j0s * j0t * s_st + j0t * j0t * s_tt + pn
    q[1, 1] = j1s * j1s * s_ss + 2.0 * j1s * j1t * s_st + j1t * j1t * s_tt + pn
    q[2, 2] = s_tt
    q[0, 1] = q[1, 0] = j0s * j1s * s_ss + (j0s * j1t + j0t * j1s) * s_st + j0t * j1t * s_tt
    q[0, 2] = q[2, 0] = j0s * s_st + j0t * s_tt
    q[1, 2] = q[2, 1] = j1s * s_st + j1t * s_tt
    q[3, 3] = prm[BIAS_WALK_VAR] * dt
    _congruence(p, f, q, tmp)
    if not math.isfinite(p[0, 0] + p[1, 1] + p[2, 2] + xn + yn):
        return BAD_STATE
    return OK


@nb.njit(cache=True)
def predict(mem: FloatArray, src: int, dst: int, t: float, dl: float, dr: float, w: float) -> int:  # pragma: no cover
    """Ring step ``dst`` = step ``src`` of a block predicted to time t [s] with the period's inputs
    (stored with it).

    Returns:
        The status of :func:`propagate`; the time and inputs are stored only when OK.
    """
    xs, ps = _ring(mem)
    x, p = mem[xs + dst], mem[ps + N * dst : ps + N * dst + N]
    copy_into(x, mem[xs + src])
    copy_rows_into(p, mem[ps + N * src : ps + N * src + N])
    f, q, tmp = mem[F_ROW:Q_ROW], mem[Q_ROW:TMP_ROW], mem[TMP_ROW:X_ROW]
    status = propagate(x, p, f, q, tmp, mem[:2].reshape(2 * N), dl, dr, w, t - mem[RING + src, 0])
    if status == OK:
        u = mem[RING + dst]
        u[0], u[1], u[2], u[3] = t, dl, dr, w
    return status


@nb.njit(cache=True)
def step(mem: FloatArray, t: float, dl: float, dr: float, w: float) -> int:  # pragma: no cover - compiled
    """One prediction of a block to time t [s] with the wheel increments (dl, dr) [rad] and the gyro
    rate w [rad/s] (ignored with the encoder heading) since the newest step, which becomes the next
    ring step (:func:`predict`; the ring's bookkeeping is updated only when it succeeds).

    Returns:
        OK; BAD_TIME (not reset, or t is not finite or not after the newest step); BAD_READING (a
        non-finite reading); or the status of :func:`predict`.
    """
    hdr = mem[NU_ROW]
    head = int(hdr[HEAD])
    if head < 0 or not (t > hdr[TIME] and math.isfinite(t)):
        return BAD_TIME
    if mem[GYRO // N, GYRO % N] == 0.0:  # the parameters, rows 0-1 flat
        w = 0.0
    if not math.isfinite(dl + dr + w):
        return BAD_READING
    cap = (mem.shape[0] - RING) // STEP_ROWS
    dst = head + 1 if head + 1 < cap else 0
    status = predict(mem, head, dst, t, dl, dr, w)
    if status == OK:
        hdr[HEAD], hdr[TIME] = dst, t
        hdr[ODO] += 0.5 * mem[RADIUS // N, RADIUS % N] * abs(dl + dr)
        if hdr[SIZE] < cap:
            hdr[SIZE] += 1
    return status


@nb.njit(cache=True, inline="always")
def _cofactors(
    a: float, b: float, c: float, d: float, e: float, f: float
) -> tuple[float, float, float, float, float, float, float]:
    """Cofactors (ca, cb, cc, cd, ce, cf) and determinant of the symmetric S = [[a, b, c], [b, d, e], [c, e, f]]."""
    ca, cb, cc = d * f - e * e, c * e - b * f, b * e - c * d
    cd, ce, cf = a * f - c * c, b * c - a * e, a * d - b * b
    return ca, cb, cc, cd, ce, cf, a * ca + b * cb + c * cc


@nb.njit(cache=True, inline="always")
def _quadratic(cof: tuple[float, float, float, float, float, float, float], n0: float, n1: float, n2: float) -> float:
    """n^T S^-1 n for the cofactors and determinant of a symmetric 3 x 3 S."""
    ca, cb, cc, cd, ce, cf, det = cof
    return (ca * n0 * n0 + cd * n1 * n1 + cf * n2 * n2 + 2.0 * (cb * n0 * n1 + cc * n0 * n2 + ce * n1 * n2)) / det


@nb.njit(cache=True)
def fix_update(
    x: FloatArray, p: FloatArray, fix: FloatArray, prm: FloatArray, gated: bool, nu: FloatArray
) -> tuple[int, float, bool]:  # pragma: no cover - compiled
    """Apply a pose fix (a row of :data:`FIX_COLS`: t_meas, z_x, z_y, z_theta, the noise covariance R's
    upper triangle by rows, then the gain G (3, 2) row by row) to (x, p) in place.

    The fix measures z = (x, y, theta) + G (s, o) + v, (s, o) the range sensor's scale and offset errors
    (states :data:`IRS`, :data:`IRO`) and v white with covariance R: H = [I_3 0 G].
    With PH = P H^T and HP its transpose (taken from P's rows, so that G = 0 gives P[:, :3] and P[:3, :]
    bit for bit), S = H P H^T + R is inverted by cofactors, K = PH S^-1 and P - K HP is re-symmetrised.
    With ``gated`` the innovation is written to ``nu`` (3,) and an outlier (NIS above the gate, when the
    filter rejects outliers) is measured but not applied.

    Returns:
        (status: OK or BAD_INNOVATION, NIS, applied).
    """
    hp = np.empty((3, N))
    ph = np.empty((N, 3))
    for r in range(3):
        g0, g1 = fix[GAIN + 2 * r], fix[GAIN + 2 * r + 1]
        for j in range(N):
            hp[r, j] = p[r, j] + g0 * p[IRS, j] + g1 * p[IRO, j]
            ph[j, r] = p[j, r] + g0 * p[j, IRS] + g1 * p[j, IRO]
    s = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            s[r, c] = hp[r, c] + fix[GAIN + 2 * c] * hp[r, IRS] + fix[GAIN + 2 * c + 1] * hp[r, IRO]
    v = fix[NOISE : NOISE + 6]
    cof = _cofactors(s[0, 0] + v[0], s[0, 1] + v[1], s[0, 2] + v[2], s[1, 1] + v[3], s[1, 2] + v[4], s[2, 2] + v[5])
    ca, cb, cc, cd, ce, cf, det = cof
    if not det > 0.0:
        return BAD_INNOVATION, math.nan, False
    n = np.empty(3)
    for r in range(3):
        n[r] = fix[1 + r] - (x[r] + fix[GAIN + 2 * r] * x[IRS] + fix[GAIN + 2 * r + 1] * x[IRO])
    n0, n1, n2 = n[0], n[1], wrap(n[2])
    nis = _quadratic(cof, n0, n1, n2)
    if gated:
        nu[0], nu[1], nu[2] = n0, n1, n2
        if prm[REJECT] != 0.0 and nis > prm[GATE]:
            return OK, nis, False
    inv_det = 1.0 / det
    k = np.empty((N, 3))
    for i in range(N):
        p0, p1, p2 = ph[i, 0], ph[i, 1], ph[i, 2]
        k[i, 0] = (p0 * ca + p1 * cb + p2 * cc) * inv_det
        k[i, 1] = (p0 * cb + p1 * cd + p2 * ce) * inv_det
        k[i, 2] = (p0 * cc + p1 * ce + p2 * cf) * inv_det
    kp = np.empty((N, N))
    for i in range(N):
        x[i] += k[i, 0] * n0 + k[i, 1] * n1 + k[i, 2] * n2
        for j in range(N):
            kp[i, j] = k[i, 0] * hp[0, j] + k[i, 1] * hp[1, j] + k[i, 2] * hp[2, j]
    x[2] = wrap(x[2])
    for i in range(N):
        for j in range(N):
            p[i, j] -= kp[i, j]
    for i in range(N):
        for j in range(i + 1, N):
            p[i, j] = p[j, i] = 0.5 * (p[i, j] + p[j, i])
    return OK, nis, True


@nb.njit(cache=True)
def rewind(mem: FloatArray, head: int, size: int, t_meas: float) -> int:  # pragma: no cover - compiled
    """Ring index of the newest of a block's ``size`` steps ending at ``head`` whose time is at or
    before t_meas [s]; -1 if all are later."""
    cap = (mem.shape[0] - RING) // STEP_ROWS
    j = head
    for _ in range(size):
        if mem[RING + j, 0] <= t_meas:
            return j
        j = j - 1 if j > 0 else cap - 1
    return -1


@nb.njit(cache=True)
def replay(
    mem: FloatArray, j: int, head: int, stored: FloatArray, new: FloatArray
) -> tuple[int, float, float, bool, bool]:  # pragma: no cover - compiled
    """Fuse a fix: apply it at ring step j (the newest at or before its measurement time,
    :func:`rewind`) and re-filter a block's ring to ``head`` with the stored fixes measured later.

    Args:
        mem: The filter's block.
        j: Ring index of the newest step at or before the new fix's measurement time.
        head: Ring index of the newest step.
        stored: (M, FIX_COLS) fixes already applied and measured after step j, in time order.
        new: (FIX_COLS,) the new fix (:func:`fix_update`); it is taken after
            stored fixes measured at the same time.

    Returns:
        (status, time of the failure [s], NIS of the new fix, applied, the newest state and
        covariance diagonal are finite). A rejected fix changes nothing.
    """
    status, t_bad, nis, ok = _refilter(mem, j, head, stored, new)
    xs, ps = _ring(mem)
    x, p = mem[xs + head], mem[ps + N * head : ps + N * head + N]
    return status, t_bad, nis, ok, math.isfinite(x[0] + x[1] + x[2] + p[0, 0] + p[1, 1] + p[2, 2])


@nb.njit(cache=True)
def _refilter(
    mem: FloatArray, j: int, head: int, stored: FloatArray, new: FloatArray
) -> tuple[int, float, float, bool]:  # pragma: no cover - compiled
    """:func:`replay` but for the finiteness: (status, time of the failure [s], NIS, applied)."""
    prm, f, q, tmp = mem[:2].reshape(2 * N), mem[F_ROW:Q_ROW], mem[Q_ROW:TMP_ROW], mem[TMP_ROW:X_ROW]
    x, p, nu = mem[X_ROW], mem[P_ROW:NU_ROW], mem[NU_ROW]
    xs, ps = _ring(mem)
    cap = xs - RING
    t_prev = mem[RING + j, 0]
    copy_into(x, mem[xs + j])
    copy_rows_into(p, mem[ps + N * j : ps + N * j + N])
    done = new[0] <= t_prev  # measured exactly at step j
    nis = math.nan
    if done:
        status, nis, ok = fix_update(x, p, new, prm, done, nu)  # done is True: a run-time bool, one compile
        if status != OK or not ok:
            return status, new[0], nis, False
        copy_into(mem[xs + j], x)
        copy_rows_into(mem[ps + N * j : ps + N * j + N], p)
    idx, fi, m = j, 0, stored.shape[0]
    while idx != head:
        idx = idx + 1 if idx + 1 < cap else 0
        t_k, dl, dr, w = mem[RING + idx, 0], mem[RING + idx, 1], mem[RING + idx, 2], mem[RING + idx, 3]
        dt = t_k - t_prev
        s = t_prev
        while True:
            is_new = not done and (fi >= m or new[0] < stored[fi, 0])
            if not is_new and fi >= m:
                break
            fx = new if is_new else stored[fi]
            if fx[0] > t_k:
                break
            if is_new:
                done = True
            else:
                fi += 1
            if fx[0] > s:
                frac = (fx[0] - s) / dt
                status = propagate(x, p, f, q, tmp, prm, dl * frac, dr * frac, w, fx[0] - s)
                if status != OK:
                    return status, fx[0], nis, False
                s = fx[0]
            status, nis_fx, ok = fix_update(x, p, fx, prm, is_new, nu)
            if status != OK:
                return status, fx[0], nis, False
            if is_new:  # always inside the first replayed period: nothing stored yet
                nis = nis_fx
                if not ok:
                    return OK, fx[0], nis, False
        if t_k > s:
            frac = (t_k - s) / dt
            status = propagate(x, p, f, q, tmp, prm, dl * frac, dr * frac, w, t_k - s)
            if status != OK:
                return status, t_k, nis, False
        copy_into(mem[xs + idx], x)
        copy_rows_into(mem[ps + N * idx : ps + N * idx + N], p)
        t_prev = t_k
    return OK, 0.0, nis, True


@nb.njit(cache=True)
def head_pose(
    mem: FloatArray, head: int, pose: FloatArray, variance: FloatArray, row: int
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Write a block's pose at ring step ``head`` and its variances into row ``row`` of (K, 3) arrays;
    return the pose."""
    xs, ps = _ring(mem)
    x, p = mem[xs + head], mem[ps + N * head : ps + N * head + N]
    pose[row, 0], pose[row, 1], pose[row, 2] = x[0], x[1], x[2]
    variance[row, 0], variance[row, 1], variance[row, 2] = p[0, 0], p[1, 1], p[2, 2]
    return x[0], x[1], x[2]


#: The finest a pose is judged at by the NEES [m, and rad alike]: a covariance claiming a pose to within it in some
#: direction (the start pose before the robot has moved, and a period or two after: the lateral position then
#: follows the heading to 1e-9 m) normalises the physics' own sub-micrometre settling, not an estimation error.
NEES_RESOLUTION = 1e-6


@nb.njit(cache=True)
def head_nees(mem: FloatArray, head: int, tx: float, ty: float, tth: float) -> float:  # pragma: no cover - compiled
    """NEES of a block's pose at ring step ``head`` against a true pose (x [m], y [m], theta [rad]),
    heading error wrapped; NaN where the pose covariance is singular or nearly so: its smallest eigenvalue
    under :data:`NEES_RESOLUTION` squared (det / the sum of the principal 2 x 2 minors, which lies between a
    third of the smallest eigenvalue and it). A pose known exactly in some direction, as a start pose before
    the robot has moved, judges nothing: no error can be normalised by it (an error of 1.8e-9 m against a
    variance of 1.3e-17 m^2 made a NEES of 1.2e15, and the mean of a run's NEES 7e12)."""
    xs, ps = _ring(mem)
    x, p = mem[xs + head], mem[ps + N * head : ps + N * head + N]
    cof = _cofactors(p[0, 0], p[0, 1], p[0, 2], p[1, 1], p[1, 2], p[2, 2])
    if not cof[6] > NEES_RESOLUTION * NEES_RESOLUTION * (cof[0] + cof[3] + cof[5]):
        return math.nan
    return _quadratic(cof, x[0] - tx, x[1] - ty, wrap(x[2] - tth))
