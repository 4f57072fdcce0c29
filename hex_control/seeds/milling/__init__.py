"""Chatter in high-speed slender ball-end milling and its surveillance by spindle-speed
variation (seed 004 section 3). SI units (m, N, s, Pa); spindle speeds in rev/min.

tool_beam            the tool as Euler-Bernoulli finite elements, its modes and tip FRF (eq. 14)
cutting              the cutting-force law of the coupling elements (eq. 11-13)
simulation           time-domain milling with the speed-dependent delay (eq. 14-16)
programmes           constant and triangular spindle programmes (Z04, Z05)
optimal_speed        the optimal-linear spindle-speed control (eq. 15-18, 10)
lobes                stability lobes by the zero-order approximation (Altintas & Budak)
semi_discretization  stability by semi-discretization (Insperger & Stepan), the check
checks               a programme judged by what it does: eq. 18 replayed, Z04/Z05 timing measured
case                 the documented case of config/milling/chatter.yaml
report, study, plots the programme table (Fig. 2-3), the study's files, the figures
"""
