"""The online shaper: a shift register of the input and a weighted sum of its taps
(seed 003 Fig. 4), for several channels at once, with bumpless shaper changes.

Impulse times are placed on the sample grid either by rounding to the nearest sample
(``interpolate=False``; a time error of up to dt/2 moves the cancelled frequency) or by
splitting each impulse linearly between its two neighbouring samples (``True``; exact for
signals linear over a sample, a small low-pass effect otherwise). ``residual_vibration`` of
:attr:`effective_shaper` says what the choice costs at the mode.
"""

from __future__ import annotations

import math

import numpy as np

from hex_control.shaping.shapers import Shaper


def _taps(shaper: Shaper, dt: float, interpolate: bool) -> np.ndarray:
    """Weights per sample delay: w[k] multiplies x[n - k]."""
    positions = shaper.times_s / dt
    weights = np.zeros(int(math.ceil(positions.max() + 1e-9)) + 2)
    for amplitude, position in zip(shaper.amplitudes, positions):
        if interpolate:
            whole = int(math.floor(position + 1e-9))
            frac = position - whole
            weights[whole] += amplitude * (1 - frac)
            weights[whole + 1] += amplitude * frac
        else:
            weights[int(round(position))] += amplitude
    return np.trim_zeros(weights, "b")


class ShaperFilter:
    """Causal shaping of a sampled stream of ``channels`` values at period ``dt_s``."""

    def __init__(self, shaper: Shaper, dt_s: float, channels: int = 1, interpolate: bool = False):
        if not (dt_s > 0 and channels >= 1):
            raise ValueError("need dt_s > 0 and channels >= 1")
        self.dt_s, self.channels, self.interpolate = dt_s, channels, interpolate
        self._weights = _taps(shaper, dt_s, interpolate)
        self.shaper = shaper
        self._old_weights = None
        self._blend_left = 0
        self._blend_total = 0
        self._history = None

    @property
    def effective_shaper(self) -> Shaper:
        """The impulse sequence actually applied (times on the sample grid)."""
        nonzero = np.flatnonzero(self._weights)
        return Shaper(self._weights[nonzero], nonzero * self.dt_s)

    @property
    def delay_s(self) -> float:
        """Until the last impulse (s): the output comes to rest this long after the input."""
        return (len(self._weights) - 1) * self.dt_s

    @property
    def lag_s(self) -> float:
        """The centroid of the applied impulses (s): at constant velocity the output is the
        input delayed by exactly this much (a ZVD's is half its duration)."""
        return float(np.arange(len(self._weights)) @ self._weights / np.sum(self._weights)) * self.dt_s

    def reset(self, value=None) -> None:
        """Forget the history; the next sample (or ``value``) fills it, so no step appears."""
        self._history = None if value is None else np.tile(np.asarray(value, float).reshape(1, self.channels),
                                                           (self._length(), 1))
        self._blend_left = 0

    def _length(self) -> int:
        old = 0 if self._old_weights is None else len(self._old_weights)
        return max(len(self._weights), old)

    def set_shaper(self, shaper: Shaper) -> None:
        """Switch shapers without a jump: the output fades from the old to the new weighted
        sum over the longer of the two durations, both reading the same input history."""
        self._old_weights = self._weights
        self._weights = _taps(shaper, self.dt_s, self.interpolate)
        self.shaper = shaper
        self._blend_total = self._blend_left = self._length()
        if self._history is not None and len(self._history) < self._length():
            pad = np.repeat(self._history[-1:], self._length() - len(self._history), axis=0)
            self._history = np.concatenate([self._history, pad])

    def step(self, sample) -> np.ndarray:
        """Push one sample (``channels`` values), return the shaped output."""
        x = np.asarray(sample, float).reshape(self.channels)
        if not np.all(np.isfinite(x)):
            raise ValueError("sample must be finite")
        if self._history is None:
            self._history = np.tile(x, (self._length(), 1))
        self._history = np.roll(self._history, 1, axis=0)
        self._history[0] = x
        new = self._weights @ self._history[: len(self._weights)]
        if self._blend_left > 0:
            old = self._old_weights @ self._history[: len(self._old_weights)]
            fraction = self._blend_left / self._blend_total
            self._blend_left -= 1
            return fraction * old + (1 - fraction) * new
        return new

    def filter(self, samples) -> np.ndarray:
        """Shape a whole array (n, channels) from a reset state (vectorized convolution)."""
        x = np.asarray(samples, float).reshape(-1, self.channels)
        padded = np.concatenate([np.repeat(x[:1], len(self._weights) - 1, axis=0), x])
        out = np.empty_like(x)
        for c in range(self.channels):
            out[:, c] = np.convolve(padded[:, c], self._weights, mode="valid")
        return out


def shape_whole(shaper: Shaper, dt_s: float, samples, interpolate: bool = False) -> tuple[np.ndarray, float]:
    """A whole sampled path (n, channels) shaped at once, as the online filter would
    stream it from rest at the first sample, continued until it comes to rest at the last
    (so the result is longer by the shaper's delay, in samples), and the filter's lag (s).

    A path planned in advance is started that lag early: then wherever it moves at
    constant velocity the shaped path is where the unshaped one is, at the same time (the
    shaper centred on its impulses' centroid, as Klipper centres its shapers), so a force
    trajectory timed against the planned path still meets the bead where it was planned.
    Left uncompensated, a 5 Hz ZVD (lag 0.1 s) puts the tool 5 mm behind its force
    trajectory at 52 mm/s."""
    x = np.asarray(samples, float)
    x = x.reshape(len(x), -1)
    if len(x) == 0 or not np.all(np.isfinite(x)):
        raise ValueError("need at least one sample, all finite")
    shaping = ShaperFilter(shaper, dt_s, x.shape[1], interpolate)
    tail = np.repeat(x[-1:], round(shaping.delay_s / dt_s), axis=0)
    return shaping.filter(np.concatenate([x, tail])), shaping.lag_s
