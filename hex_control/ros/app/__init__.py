"""The applications on the graph: the job session and graph runner (``hexctl demo``), a
campaign's cell (``hexctl campaign``), the load predictor demo."""
