"""GNSS-SDR's configuration for the benchmarks that run it as the peer on a gps-sdr-sim file:
file source, PCPS acquisition, DLL/PLL tracking, telemetry, observables and a
single-point PVT, with what the benchmarks vary as parameters."""

from __future__ import annotations

from pathlib import Path

#: Sample type of the file (GNSS-SDR's ``item_type``) -> its data-type adapter.
ADAPTERS = {"ibyte": "Ibyte_To_Complex", "ishort": "Ishort_To_Complex"}

#: The ``Acquisition_1C`` section: PCPS, 1 ms coherent, +-5 kHz in 250 Hz steps, one dwell.
ACQUISITION = {
    "implementation": "GPS_L1_CA_PCPS_Acquisition",
    "item_type": "gr_complex",
    "coherent_integration_time_ms": 1,
    "pfa": 0.01,
    "doppler_max": 5000,
    "doppler_step": 250,
    "max_dwells": 1,
}
#: The ``Tracking_1C`` section: DLL/PLL, 30 Hz PLL, 2 Hz DLL, early-late 0.5 chip.
TRACKING = {
    "implementation": "GPS_L1_CA_DLL_PLL_Tracking",
    "item_type": "gr_complex",
    "pll_bw_hz": 30.0,
    "dll_bw_hz": 2.0,
    "early_late_space_chips": 0.5,
}
#: Weak-signal overrides of `ACQUISITION` (the peer's own options for a weak signal, our
#: choice where its docs give none): 10 ms coherent blocks with its bit-transition search
#: (two blocks, the better taken), Doppler steps of half the 100 Hz bin.
WEAK_ACQUISITION = {"coherent_integration_time_ms": 10, "bit_transition_flag": "true", "doppler_step": 50}
#: Weak-signal overrides of `TRACKING`: a 15 Hz PLL and 1 Hz DLL to pull in, then 20 ms
#: coherent sums once the bit is synchronised with a 5 Hz PLL and 0.5 Hz DLL; the loss-of-lock
#: tests relaxed: C/N0 down to 20 dB-Hz, the carrier lock indicator (cos 2 phi, 0.85 by
#: default: 1 ms sums at 30 dB-Hz read 0.5 in lock) down to 0.3, as `receive --weak`'s.
WEAK_TRACKING = {
    "pll_bw_hz": 15.0,
    "dll_bw_hz": 1.0,
    "extend_correlation_symbols": 20,
    "pll_bw_narrow_hz": 5.0,
    "dll_bw_narrow_hz": 0.5,
    "early_late_space_narrow_chips": 0.5,
    "cn0_min": 20,
    "carrier_lock_th": 0.3,
}


def section(block: str, settings: dict[str, object]) -> str:
    """GNSS-SDR config lines ``block.key=value`` of ``settings``, in their order (values as
    Python prints them: ``30.0`` stays ``30.0``)."""
    return "".join(f"{block}.{key}={value}\n" for key, value in settings.items())


def gnss_sdr_config(
    path: Path,
    fs: float,
    out: Path,
    *,
    channels: int = 8,
    item_type: str = "ibyte",
    output_rate_ms: int = 100,
    display_rate_ms: int = 500,
    pvt_models: bool = False,
    acquisition: dict[str, object] | None = None,
    tracking: dict[str, object] | None = None,
) -> str:
    """The text of a GNSS-SDR 0.0.17 config for GPS L1 C/A on interleaved I/Q ``path``.

    ``item_type`` is ``ibyte`` (int8 I/Q) or ``ishort`` (int16 I/Q); ``pvt_models`` adds
    the broadcast ionosphere and no troposphere to the PVT (as our position solution);
    ``acquisition`` and ``tracking`` override or add keys of `ACQUISITION` and `TRACKING`
    (`WEAK_ACQUISITION`, `WEAK_TRACKING`).
    """
    if item_type not in ADAPTERS:
        raise ValueError(f"item_type {item_type!r}: one of {', '.join(ADAPTERS)}")
    models = "PVT.iono_model=Broadcast\nPVT.trop_model=OFF\n" if pvt_models else ""
    return f"""[GNSS-SDR]
GNSS-SDR.internal_fs_sps={fs:.0f}
SignalSource.implementation=File_Signal_Source
SignalSource.filename={path}
SignalSource.item_type={item_type}
SignalSource.sampling_frequency={fs:.0f}
SignalSource.samples=0
SignalSource.repeat=false
SignalConditioner.implementation=Signal_Conditioner
DataTypeAdapter.implementation={ADAPTERS[item_type]}
InputFilter.implementation=Pass_Through
InputFilter.item_type=gr_complex
Resampler.implementation=Pass_Through
Resampler.item_type=gr_complex
Channels_1C.count={channels}
Channels.in_acquisition=1
Channel.signal=1C
{section("Acquisition_1C", ACQUISITION | (acquisition or {}))}{section("Tracking_1C", TRACKING | (tracking or {}))}\
TelemetryDecoder_1C.implementation=GPS_L1_CA_Telemetry_Decoder
Observables.implementation=Hybrid_Observables
PVT.implementation=RTKLIB_PVT
PVT.positioning_mode=Single
{models}PVT.output_rate_ms={output_rate_ms}
PVT.display_rate_ms={display_rate_ms}
PVT.output_path={out}
"""
