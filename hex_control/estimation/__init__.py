"""Estimation: one-step-ahead Kalman prediction of Gauss-Markov load fluctuations.

Seed 000, part 2 (Stochastic Unit Commitment...), section 6, eqs 6.2-6.7.
"""

from hex_control.estimation.gauss_markov import GaussMarkovModel
from hex_control.estimation.identify import Identification, identify, method_of_moments
from hex_control.estimation.kalman import (
    MultiChannelPredictor,
    OneStepPredictor,
    PredictionSeries,
    predict_series,
)
from hex_control.estimation.skill import expected_skill, skill_score

__all__ = [
    "GaussMarkovModel",
    "Identification",
    "MultiChannelPredictor",
    "OneStepPredictor",
    "PredictionSeries",
    "identify",
    "method_of_moments",
    "predict_series",
    "expected_skill",
    "skill_score",
]
