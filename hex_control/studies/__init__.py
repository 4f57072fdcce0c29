"""Studies of a controller on the plant (no ROS): ITAE tuning of the force loop's PI and the
thesis's force-loop study (seed 002 ch. 7). They need both ``control`` and ``plant``, so they
sit above them."""
