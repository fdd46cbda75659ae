"""Readers and writers of GNSS data files (NMEA through pynmea2, RINEX through georinex) and the atomic result files."""
