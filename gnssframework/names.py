"""The names sequential filters exchange: every ``requires`` and ``provides`` entry, and
the further inputs a harness hands a ``step()`` (NCO shifts, satellite states).

One module, so a plugin and a harness cannot spell a name two ways: it is the contract
between them. The harnesses spell their step inputs and the outputs they read through it
(`gnssframework.receiver.tracking.scalar`, `gnssframework.receiver.tracking.vector`,
`gnssframework.io.smoothing`), a plugin declares ``requires = (names.CORRELATORS,)``,
and the harness checks that ``step()`` returned everything the plugin ``provides``
(``SequentialFilter.checked_step``). ``tests/core/test_names.py`` holds every key that a
built-in plugin or a harness reads or hands over, spelt literally or through this
module, to the names below.

Examples
--------
>>> from gnssframework import names
>>> names.CODE_ERROR_CHIPS
'code_error_chips'
>>> "code_error_chips" in names.ALL
True
"""

from __future__ import annotations

# -- channel filter inputs ----------------------------------------------------------
CORRELATORS = "correlators"  #: gnssframework.Correlators of one coherent interval
PSEUDORANGE_M = "pseudorange_m"
CARRIER_M = "carrier_m"  #: carrier phase times the wavelength

# -- inputs a vector or aided-tracking harness adds to a channel filter's step ---------
NCO_SHIFT_CHIPS = "nco_shift_chips"  #: code NCO shift since the last interval, by the nav filter's command
NCO_SHIFT_HZ = "nco_shift_hz"  #: carrier NCO frequency shift since the last interval
DATA_BIT = "data_bit"  #: the navigation data bit (+-1), only where the harness knows it

# -- input a recorded-data harness adds to a smoother's step ------------------------------
ARC_START = "arc_start"  #: True where a carrier arc starts: the receiver's loss-of-lock flag or a gap

# -- scalar / carrier loop outputs ---------------------------------------------------
CARRIER_FREQ_HZ = "carrier_freq_hz"
CODE_FREQ_HZ = "code_freq_hz"
CARRIER_PHASE_STEP_RAD = "carrier_phase_step_rad"
CODE_DISC_CHIPS = "code_disc_chips"
PHASE_DISC_RAD = "phase_disc_rad"
FREQ_DISC_HZ = "freq_disc_hz"

# -- vector-loop channel outputs (nav filter inputs) ---------------------------------
CODE_ERROR_CHIPS = "code_error_chips"
CODE_ERROR_VAR_CHIPS2 = "code_error_var_chips2"
FREQ_ERROR_HZ = "freq_error_hz"
FREQ_ERROR_VAR_HZ2 = "freq_error_var_hz2"
AMPLITUDE = "amplitude"
PHASE_ERROR_RAD = "phase_error_rad"

# -- inputs the vector loop adds to a nav filter's step ----------------------------------
SAT_POS_M = "sat_pos_m"  #: satellite ECEF positions at mid-interval, (..., channels, 3)
SAT_VEL_M_S = "sat_vel_m_s"
NEXT_SAT_POS_M = "next_sat_pos_m"  #: at the start of the next interval (for the NCO command)
NEXT_SAT_VEL_M_S = "next_sat_vel_m_s"
REPLICA_RANGE_M = "replica_range_m"  #: the replica's range at mid-interval
REPLICA_RATE_M_S = "replica_rate_m_s"

# -- carrier smoothing outputs ---------------------------------------------------------
SMOOTHED_M = "smoothed_m"
SLIP_DETECTED = "slip_detected"

# -- navigation filter outputs ---------------------------------------------------------
POSITION_M = "position_m"
VELOCITY_M_S = "velocity_m_s"
CLOCK_M = "clock_m"  #: clock bias (m) and drift (m/s)
COV = "cov"
NCO_RANGE_M = "nco_range_m"
NCO_RANGE_RATE_M_S = "nco_range_rate_m_s"

# deep GNSS/INS integration (``ins-ekf``)
RESIDUAL_M = "residual_m"  #: per channel range (m) and rate (m/s) residual against the INS, (runs, ch, 2)
RESIDUAL_COV = "residual_cov"  #: their 2x2 covariances, (runs, ch, 2, 2)
ERROR_STATE = "error_state"  #: the 15-state error estimate to subtract from the INS, (runs, 15)

#: Every name above.
ALL = frozenset(v for k, v in dict(globals()).items() if k.isupper() and isinstance(v, str))
