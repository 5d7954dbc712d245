"""The estimation figure: each pose estimate against the true pose, with its 2-sigma envelope and the
position fixes it was given.

Three axes against time: the x and y position errors [m] and the wrapped heading error [rad] of each
estimate (estimate minus truth), each in its run's colour (:func:`sim.viz.scene.run_styles`); where a
covariance is given, the band of plus and minus two standard deviations of that coordinate around
zero (a consistent estimator keeps about 95 % of its error inside); where fixes are given, the error
of each fix against the truth at its time as dots. The run log has no estimates yet, so the figure
takes plain arrays.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from planning.core.geometry import wrap_angle
from planning.errors import ConfigError
from sim.physics.runlog import RunLog
from sim.viz.plots.draw import tight
from sim.viz.scene import run_styles

FloatArray = NDArray[np.float64]

#: Axis labels of the three coordinates.
_AXES = ("x error [m]", "y error [m]", "heading error [rad]")


def _series(name: str, value: object, shape: tuple[int | None, ...]) -> FloatArray:
    """``value`` as a finite float array of ``shape`` (None: any length), else a ConfigError naming it."""
    arr = np.asarray(value, dtype=float)
    ok = arr.ndim == len(shape) and all(n is None or n == m for n, m in zip(shape, arr.shape, strict=True))
    if not ok:
        want = "(" + ", ".join("M" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ConfigError(f"estimation: {name} has shape {arr.shape}, expected {want}; pass one row per time")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"estimation: {name} holds NaN or infinite values; pass finite numbers")
    return arr


def _times(name: str, value: object) -> FloatArray:
    t = _series(name, value, (None,))
    if t.size < 1 or np.any(np.diff(t) <= 0.0):
        raise ConfigError(f"estimation: {name} must be non-empty and strictly increasing [s]; sort the samples")
    return t


def estimation_figure(
    t: FloatArray,
    truth: FloatArray,
    estimates: Mapping[str, FloatArray],
    fixes: Mapping[str, tuple[FloatArray, FloatArray]] | None = None,
    cov: Mapping[str, FloatArray] | None = None,
    *,
    title: str = "",
) -> Figure:
    """Position and heading error of each estimate against the truth, with 2-sigma envelopes and fixes.

    Args:
        t: (N,) times [s], strictly increasing.
        truth: (N, 3) true pose [x, y, theta] [m, m, rad] at ``t`` (theta wrapped or not).
        estimates: Run label -> (N, 3) estimated pose at ``t``.
        fixes: Run label -> ((M,) fix times [s], strictly increasing within ``t``'s span, (M, 3) fixed
            poses); each fix's error is taken against the truth interpolated to its time.
        cov: Run label -> (N, 3, 3) covariance of the estimate [m^2, rad^2]; a label of ``estimates``.
        title: Figure title.

    Returns:
        A figure of three axes (x error, y error, heading error against time).

    Raises:
        ConfigError: An array of the wrong shape, not finite, times not increasing, a fix outside
            the span of ``t``, a covariance of an unknown label or with a negative variance.
    """
    t = _times("t", t)
    n = t.size
    truth = _series("truth", truth, (n, 3))
    est = {label: _series(f"estimates[{label!r}]", e, (n, 3)) for label, e in estimates.items()}
    covs = {label: _series(f"cov[{label!r}]", c, (n, 3, 3)) for label, c in (cov or {}).items()}
    for label, c in covs.items():
        if label not in est:
            raise ConfigError(f"estimation: cov[{label!r}] has no estimate; give estimates[{label!r}] or drop it")
        if np.any(np.diagonal(c, axis1=1, axis2=2) < 0.0):
            raise ConfigError(f"estimation: cov[{label!r}] has a negative variance; pass covariance matrices")
    fix = {label: _fix(label, tz, t) for label, tz in (fixes or {}).items()}
    styles = run_styles([*est, *fix])

    fig = Figure(figsize=(8.0, 7.6), dpi=110)
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    for label, e in est.items():
        st = styles[label]
        err = _errors(e, truth)
        for i, ax in enumerate(axes):
            ax.plot(t, err[:, i], color=st.rgba, ls=st.linestyle, lw=1.2, label=st.name)
            if label in covs:
                two_sigma = 2.0 * np.sqrt(covs[label][:, i, i])
                ax.fill_between(t, -two_sigma, two_sigma, color=st.rgba, alpha=0.15, lw=0, label=f"{st.name} ±2σ")
    for label, (tf, z) in fix.items():
        st = styles[label]
        smooth = np.column_stack([truth[:, :2], np.unwrap(truth[:, 2])])  # no jump of 2 pi to interpolate across
        at_fix = np.column_stack([np.interp(tf, t, smooth[:, i]) for i in range(3)])
        err = _errors(z, at_fix)
        for i, ax in enumerate(axes):
            ax.plot(tf, err[:, i], "o", ms=3.0, color=st.rgba, ls="none", label=f"{st.name} fixes")
    for ax, ylabel in zip(axes, _AXES, strict=True):
        ax.axhline(0.0, color="0.4", lw=0.6)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(title or "estimates against the true pose")
    tight(fig)
    return fig


def _fix(label: str, value: tuple[FloatArray, FloatArray], t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """A run's fixes checked: (M,) times within ``t``'s span and (M, 3) poses."""
    try:
        tf_raw, z_raw = value
    except (TypeError, ValueError):
        raise ConfigError(f"estimation: fixes[{label!r}] must be a pair (times (M,), poses (M, 3))") from None
    tf = _times(f"fixes[{label!r}] times", tf_raw)
    z = _series(f"fixes[{label!r}] poses", z_raw, (tf.size, 3))
    if tf[0] < t[0] or tf[-1] > t[-1]:
        raise ConfigError(
            f"estimation: fixes[{label!r}] span [{tf[0]:g}, {tf[-1]:g}] s reaches outside the truth's "
            f"[{t[0]:g}, {t[-1]:g}] s; drop the fixes outside it"
        )
    return tf, z


def _errors(pose: FloatArray, truth: FloatArray) -> FloatArray:
    """(K, 3) pose minus truth, the heading wrapped to [-pi, pi)."""
    err = pose - truth
    err[:, 2] = wrap_angle(err[:, 2])
    return err


@dataclass(frozen=True)
class EstimationSeries:
    """What :func:`estimation_figure` plots, as one value (the input ``job_figures`` takes).

    Attributes:
        t: (N,) times [s].
        truth: (N, 3) true pose.
        estimates: Run label -> (N, 3) estimated pose.
        fixes: Run label -> ((M,) times, (M, 3) fixed poses), or None.
        cov: Run label -> (N, 3, 3) covariance of the estimate, or None.
    """

    t: FloatArray
    truth: FloatArray
    estimates: Mapping[str, FloatArray]
    fixes: Mapping[str, tuple[FloatArray, FloatArray]] | None = None
    cov: Mapping[str, FloatArray] | None = None

    def figure(self, *, title: str = "") -> Figure:
        """The estimation figure of these series."""
        return estimation_figure(self.t, self.truth, self.estimates, self.fixes, self.cov, title=title)


def series_of_runs(logs: Mapping[str, RunLog]) -> EstimationSeries | None:
    """The estimation series of a job's runs fed by an estimator (None when no run had an estimate).

    Each run drove its own robot, so each estimate is compared with its own truth: the series holds
    the errors (estimate minus truth, heading wrapped) against a zero "truth", which the figure
    plots exactly as it would the estimate against that run's truth. Runs are cut to the shortest
    (a run whose estimator diverged ends early).
    """
    # (a run whose global localisation chose no pose has an estimator and no estimate)
    est = {label: log.estimation for label, log in logs.items() if log.estimation is not None and log.estimation.t.size}
    if not est:
        return None
    n = min(e.t.size for e in est.values())
    t = next(iter(est.values())).t[:n]
    errors, fixes, cov = {}, {}, {}
    for label, e in est.items():
        err = e.estimate[:n] - e.truth[:n]
        err[:, 2] = np.remainder(err[:, 2] + np.pi, 2 * np.pi) - np.pi
        errors[label] = err
        cov[label] = np.stack([np.diag(v) for v in e.variance[:n]])
        if e.fix_t.size and e.fix_applied.any():
            k = np.searchsorted(e.t, e.fix_t[e.fix_applied])
            keep = k < n
            ferr = e.fix[e.fix_applied][keep] - e.truth[k[keep]]
            ferr[:, 2] = np.remainder(ferr[:, 2] + np.pi, 2 * np.pi) - np.pi
            fixes[label] = (e.fix_t[e.fix_applied][keep], ferr)
    return EstimationSeries(t, np.zeros((n, 3)), errors, fixes or None, cov)
