"""One-step prediction of a load that may start to drift: an interacting multiple model.

Seed 000's predictor (eqs 6.2-6.7, :mod:`hex_control.estimation.kalman`) assumes the
fluctuation returns to its mean. A grinding disk that dulls does not: its specific energy
K1 climbs pass after pass, and a filter of that model lags the climb by the inverse of its
gain. This predictor runs two models on the state x = (dL, r), dL the fluctuation about
``mean`` and r its drift per sample, and weighs them by how well each predicted the data:

    steady:    dL(t+1) = a dL(t) + w(t),          r(t+1) = 0               (eq. 6.2)
    drifting:  dL(t+1) = dL(t) + r(t) + w(t),     r(t+1) = r(t) + w_r(t)   (local linear trend)
    y(t) = dL(t) + v(t)                                                   (eq. 6.3)

with E[w^2] = W, E[v^2] = V from the Gauss-Markov model and E[w_r^2] = ``rate_variance``.
The mode switches with probability ``switch_probability`` per sample (a Markov chain).
The filter is the IMM of Blom and Bar-Shalom (IEEE Trans. Automatic Control 33(8), 1988;
Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
2001, section 11.6.6): per sample, each mode's Kalman update, the mode probabilities from
the measurement's likelihood under each mode, then the mixing of the modes' estimates and
each mode's prediction. Its ``drift_probability`` -- the drifting mode's posterior
probability -- is the detector: a dull disk is flagged when it passes one half. The
one-step prediction of y(t+1) weighs the modes by their predicted probabilities.

Written out in scalars for two states and a scalar measurement, it runs 10-15x faster
than filterpy's general ``IMMEstimator`` (40-65 us against 580-740 us a sample, side by
side on this machine under load) and agrees with it to rounding (``test_drift.py``).

Loads in the caller's unit; ``rate_variance`` in that unit squared per sample squared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hex_control.estimation.gauss_markov import GaussMarkovModel
from hex_control.estimation.kalman import PredictionStep

STEADY, DRIFTING = 0, 1


@dataclass(frozen=True)
class DriftStep(PredictionStep):
    """A prediction step and what the drifting mode says about it."""

    drift_probability: float = 0.0  # posterior probability of the drifting mode after y(t)
    drift_per_sample: float = 0.0  # the IMM's estimate of r (load unit per sample)


@dataclass
class _Mode:
    """One mode's estimate of (dL, r) and its covariance [[pll, plr], [plr, prr]]."""

    level: float
    rate: float
    pll: float
    plr: float
    prr: float

    def update(self, y: float, v: float) -> tuple[float, float, float]:
        """Kalman update with y = dL + v, E[v^2] = V; returns the likelihood of y and the
        gains (kl, kr) of the level and the rate."""
        s = self.pll + v
        kl, kr = self.pll / s, self.plr / s
        innovation = y - self.level
        self.level += kl * innovation
        self.rate += kr * innovation
        self.pll, self.plr, self.prr = (1 - kl) * self.pll, (1 - kl) * self.plr, self.prr - kr * self.plr
        return math.exp(-0.5 * innovation * innovation / s) / math.sqrt(2 * math.pi * s), kl, kr


def _mix(modes: list[_Mode], weights) -> _Mode:
    """The Gaussian mixture's mean and covariance (the spread of the means included)."""
    level = sum(w * m.level for w, m in zip(weights, modes))
    rate = sum(w * m.rate for w, m in zip(weights, modes))
    pll = sum(w * (m.pll + (m.level - level) ** 2) for w, m in zip(weights, modes))
    plr = sum(w * (m.plr + (m.level - level) * (m.rate - rate)) for w, m in zip(weights, modes))
    prr = sum(w * (m.prr + (m.rate - rate) ** 2) for w, m in zip(weights, modes))
    return _Mode(level, rate, pll, plr, prr)


class DriftingLoadPredictor:
    """Streaming IMM predictor; the interface of :class:`~hex_control.estimation.OneStepPredictor`
    (``step``, ``reset``, ``prediction``, ``prediction_variance``, ``sample_count``, and the
    ``model`` and ``mean`` a retuning may replace)."""

    def __init__(self, model: GaussMarkovModel, mean: float = 0.0, rate_variance: float = 0.5,
                 switch_probability: float = 0.05, initial_rate_variance: float | None = None):
        if not math.isfinite(mean):
            raise ValueError(f"mean must be finite, got {mean!r}")
        if not (math.isfinite(rate_variance) and rate_variance > 0):
            raise ValueError(f"rate_variance must be finite and > 0, got {rate_variance!r}")
        if not 0 < switch_probability < 0.5:  # 0 would divide by a mode probability of 0
            raise ValueError(f"switch_probability must be in (0, 0.5), got {switch_probability!r}")
        initial_rate_variance = rate_variance if initial_rate_variance is None else initial_rate_variance
        if not (math.isfinite(initial_rate_variance) and initial_rate_variance >= 0):
            raise ValueError(f"initial_rate_variance must be finite and >= 0, got {initial_rate_variance!r}")
        self.model = model
        self.mean = float(mean)
        self.rate_variance = float(rate_variance)
        self.initial_rate_variance = float(initial_rate_variance)
        self.switch_probability = float(switch_probability)
        self.reset()

    def reset(self) -> None:
        """Forget the history: dL = 0 with P(0) = sigma(0), the drift r = 0 with
        ``initial_rate_variance``, and the chain in the steady mode with probability
        1 - switch_probability."""
        p0 = self.model.p0
        self._modes = [_Mode(0.0, 0.0, p0, 0.0, 0.0), _Mode(0.0, 0.0, p0, 0.0, self.initial_rate_variance)]
        self._predicted_mode = [1.0 - self.switch_probability, self.switch_probability]  # P(mode at t | y to t-1)
        self._mode = list(self._predicted_mode)  # P(mode at t | y to t)
        self.sample_count = 0

    def _prior(self) -> _Mode:
        """dL(t|t-1) and its variance: the modes' priors weighed by the predicted mode probabilities."""
        return _mix(self._modes, self._predicted_mode)

    @property
    def prediction(self) -> float:
        """Current prediction of the next load, mean + dL(t+1|t)."""
        return self.mean + self._prior().level

    @property
    def prediction_variance(self) -> float:
        return self._prior().pll

    @property
    def drift_probability(self) -> float:
        return self._mode[DRIFTING]

    def step(self, measurement: float) -> DriftStep:
        """Filter y(t) = ``measurement`` and advance to the prediction of L(t+1)."""
        if not math.isfinite(measurement):
            raise ValueError(f"measurement must be finite, got {measurement!r}")
        prior = self._prior()
        y = measurement - self.mean
        updates = [m.update(y, self.model.measurement_variance) for m in self._modes]
        weights = [c * likelihood for c, (likelihood, _, _) in zip(self._predicted_mode, updates)]
        total = sum(weights)
        # a measurement so far out that both likelihoods underflow says nothing about the mode
        self._mode = [w / total for w in weights] if total > 0 else list(self._predicted_mode)
        posterior = _mix(self._modes, self._mode)
        # seed 000's K(t): how far dL(t+1|t) moves per unit of innovation (a kl, or kl + kr)
        (_, kl_steady, _), (_, kl_drifting, kr_drifting) = updates
        gain = self._mode[STEADY] * self.model.a * kl_steady + self._mode[DRIFTING] * (kl_drifting + kr_drifting)
        # mixing: each mode starts the next step from the mixture its predecessors hand it
        p = self.switch_probability
        switch = ((1 - p, p), (p, 1 - p))  # switch[i][j] = P(mode j next | mode i now)
        self._predicted_mode = [sum(self._mode[i] * switch[i][j] for i in (0, 1)) for j in (0, 1)]
        mixed = [_mix(self._modes, [self._mode[i] * switch[i][j] / self._predicted_mode[j] for i in (0, 1)])
                 for j in (0, 1)]
        a, w = self.model.a, self.model.process_variance
        steady, drifting = mixed
        self._modes = [
            _Mode(a * steady.level, 0.0, a * a * steady.pll + w, 0.0, 0.0),  # eq. 6.2; r held at 0
            _Mode(drifting.level + drifting.rate, drifting.rate,
                  drifting.pll + 2 * drifting.plr + drifting.prr + w, drifting.plr + drifting.prr,
                  drifting.prr + self.rate_variance)]  # dL += r, r random walk
        prediction = self._prior()
        self.sample_count += 1
        return DriftStep(measurement=float(measurement), prior=self.mean + prior.level, innovation=y - prior.level,
                         innovation_variance=prior.pll + self.model.measurement_variance, gain=gain,
                         prediction=self.mean + prediction.level, prediction_variance=prediction.pll,
                         drift_probability=self._mode[DRIFTING], drift_per_sample=posterior.rate)
