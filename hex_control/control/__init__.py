"""Controllers: the digital PI of the force loop (seed 002 ch. 7) and filters for it."""
