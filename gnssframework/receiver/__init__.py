"""The software receiver by role: ``frontend`` (IF samples), ``acquisition``, ``channels``, ``tracking`` (loops,
scalar and vector tracking, bounds) and ``deep`` (INS-aided tracking)."""
