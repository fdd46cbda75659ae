"""Galileo E1 OS signals (plugin kind ``signal``): E1-B and E1-C, CBOC or a BOC(1,1) replica."""

from __future__ import annotations

from gnssframework.signal.galileo_e1 import GALILEO_E1B, GALILEO_E1B_BOC11, GALILEO_E1C, GALILEO_E1C_BOC11
from gnssframework.signal.galileo_e5a import GALILEO_E5AI, GALILEO_E5AQ
from gnssframework.signal.registered import Signal

__all__ = ["GalileoE1b", "GalileoE1c", "GalileoE1bBoc11", "GalileoE1cBoc11", "GalileoE5ai", "GalileoE5aq"]


class GalileoE1b(Signal):
    """Galileo E1-B: the data component of E1 OS, CBOC(6,1,1/11), 4092-chip memory codes (OS SIS ICD)."""

    name = "galileo-e1b"
    spec = GALILEO_E1B
    description = "Galileo E1-B: CBOC(6,1,1/11) at 1575.42 MHz, 4092-chip memory codes, PRN 1-50, 250 sym/s I/NAV"


class GalileoE1c(Signal):
    """Galileo E1-C: the pilot of E1 OS, CBOC(6,1,1/11), secondary code CS25_1 (OS SIS ICD)."""

    name = "galileo-e1c"
    spec = GALILEO_E1C
    description = "Galileo E1-C pilot: CBOC(6,1,1/11) at 1575.42 MHz, 4092-chip memory codes, CS25_1 overlay, PRN 1-50"


class GalileoE1bBoc11(Signal):
    """Galileo E1-B with a BOC(1,1) replica (a narrow-band receiver's)."""

    name = "galileo-e1b-boc11"
    spec = GALILEO_E1B_BOC11
    description = "Galileo E1-B, BOC(1,1) replica of its CBOC(6,1,1/11) (0.41 dB loss; +-1 correlator tables)"


class GalileoE1cBoc11(Signal):
    """Galileo E1-C with a BOC(1,1) replica (a narrow-band receiver's)."""

    name = "galileo-e1c-boc11"
    spec = GALILEO_E1C_BOC11
    description = "Galileo E1-C pilot, BOC(1,1) replica of its CBOC(6,1,1/11), CS25_1 overlay"


class GalileoE5ai(Signal):
    """Galileo E5a-I, the data component tracked: CS20_1 overlay, 50 sps F/NAV (OS SIS ICD)."""

    name = "galileo-e5ai"
    spec = GALILEO_E5AI
    description = (
        "Galileo E5a-I: BPSK(10) at 1176.45 MHz, 10230-chip codes (1 ms), CS20 overlay, 50 sps F/NAV, PRN 1-50"
    )


class GalileoE5aq(Signal):
    """Galileo E5a-Q, the pilot tracked: each PRN's CS100 overlay (OS SIS ICD)."""

    name = "galileo-e5aq"
    spec = GALILEO_E5AQ
    description = (
        "Galileo E5a-Q pilot: BPSK(10) at 1176.45 MHz, 10230-chip codes (1 ms), per-PRN CS100 overlay, PRN 1-50"
    )
