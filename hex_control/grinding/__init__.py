"""Grinding: the static/stochastic process model and the sequence planner (seed 002 ch. 4-5).

Units: mm, N, s (power W, energy J); charges in arbitrary currency units.
"""
