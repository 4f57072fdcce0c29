"""The source papers' systems outside the grinding cell (no ROS), each with its own
``hexctl`` verb, plots and tests that name the seed's equations and figures:

- :mod:`.unit_commitment`: seed 000 part 2, stochastic unit commitment and dispatch;
- :mod:`.milling`: seed 004 section 3, chatter of a slender ball-end mill;
- :mod:`.mobile_platform`: seed 004 section 4, a two-wheeled platform.

They reuse the cell's library floors (estimation, control) and nothing of the cell's
nodes; nothing of the cell imports them.
"""
