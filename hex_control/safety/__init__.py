"""Rules that keep one stray or forged input from commanding the cell (no ROS).

- :mod:`.command_owner`: which publishers an input obeys (authority by configuration).
"""
