"""Stochastic unit commitment scheduling and dispatch (seed 000 part 2, Yan & Blankenship):
the fleets and their costs (fleet), economic dispatch (dispatch), the K cheapest
commitments (commitments), the scheduling table (table), storage flattening (storage),
the example day (demand), the off-line day (day), the MILP peer (milp), on-line
scheduling on the Kalman predictor (online), plots and the CLI's jobs (plots, report).
No ROS; docs/unit_commitment.md.

Units: generation in MW, time in hours, costs in the paper's cost units (per hour for
running costs, per start for starting costs), incremental cost lambda in cost units per MWh.
"""
