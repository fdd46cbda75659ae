"""The receiver's navigation stage: navigation bits from tracked channels, observables at common epochs, a fix per epoch, and the recording-to-positions driver with its RINEX and NMEA outputs."""
