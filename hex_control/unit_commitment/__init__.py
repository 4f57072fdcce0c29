"""Stochastic unit commitment scheduling and dispatch (seed 000 part 2, Yan & Blankenship):
the generation system's model (section 2) and economic dispatch (eq. 2.7). No ROS.

Units: generation in MW, time in hours, costs in the paper's cost units (per hour for
running costs, per start for starting costs), incremental cost lambda in cost units per MWh.
"""
