"""Navigation: satellite states from broadcast ephemerides, shared by simulation and receivers."""
