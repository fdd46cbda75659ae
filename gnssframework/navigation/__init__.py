"""Navigation: satellite states from broadcast ephemerides and receiver-satellite geometry, shared by simulation and receivers."""
