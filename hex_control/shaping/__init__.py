"""Input shaping (seed 003, Hubinsky, Jurisica, Vranka 2005): impulse sequences, residual
vibration, evolution-optimized sequences and the online shift-register filter.

Units: frequencies in Hz, times in s, damping ratio dimensionless.
"""
