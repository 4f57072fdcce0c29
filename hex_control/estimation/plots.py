"""Figures for the load predictor (PNG via matplotlib's Agg backend)."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save


def plot_prediction(path, time_s, measurement, prediction, prediction_std, *, quantity: str,
                    title: str = "") -> None:
    """Measurement y(t+1) against its one-step prediction made at t, with a +-2 sigma band.

    ``prediction[i]`` predicts ``measurement[i + 1]``; it is drawn at the time of its target.
    ``prediction_std`` is the standard deviation of y(t+1) - prediction, sqrt(P(t+1) + V).
    """
    t = np.asarray(time_s)
    y = np.asarray(measurement)
    p = np.asarray(prediction)[:-1]
    s = np.asarray(prediction_std)[:-1]
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(10, 6), sharex=True,
                                     gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(t, y, color="0.55", lw=0.8, label="measurement y(t)")
    ax.plot(t[1:], p, color="C0", lw=1.2, label="prediction L(t|t-1)")
    ax.fill_between(t[1:], p - 2 * s, p + 2 * s, color="C0", alpha=0.2, label="±2σ of y(t) − L(t|t−1)")
    ax.set_ylabel(quantity)
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(title or "One-step-ahead Kalman prediction (seed 000 part 2, eqs 6.6-6.7)")
    ax_err.plot(t[1:], y[1:] - p, color="C3", lw=0.7, label="prediction error")
    ax_err.plot(t[1:], y[1:] - y[:-1], color="0.6", lw=0.5, alpha=0.7, label="persistence error")
    ax_err.set_xlabel("time (s)")
    ax_err.legend(loc="upper right", fontsize="small")
    save(fig, path)
