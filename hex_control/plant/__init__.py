"""The simulated hardware: force table, sensor, disturbances (seed 002 ch. 7)."""
