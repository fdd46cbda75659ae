"""GNSS-SDR's configuration for the benchmarks that run it as the peer on a gps-sdr-sim file:
file source, PCPS acquisition, DLL/PLL tracking, telemetry, observables and a
single-point PVT, with what the benchmarks vary as parameters."""

from __future__ import annotations

from pathlib import Path

#: Sample type of the file (GNSS-SDR's ``item_type``) -> its data-type adapter.
ADAPTERS = {"ibyte": "Ibyte_To_Complex", "ishort": "Ishort_To_Complex"}


def gnss_sdr_config(path: Path, fs: float, out: Path, *, channels: int = 8, item_type: str = "ibyte",
                    output_rate_ms: int = 100, display_rate_ms: int = 500, pvt_models: bool = False) -> str:
    """The text of a GNSS-SDR 0.0.17 config for GPS L1 C/A on interleaved I/Q ``path``.

    ``item_type`` is ``ibyte`` (int8 I/Q) or ``ishort`` (int16 I/Q); ``pvt_models`` adds
    the broadcast ionosphere and no troposphere to the PVT (as our position solution).
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
Acquisition_1C.implementation=GPS_L1_CA_PCPS_Acquisition
Acquisition_1C.item_type=gr_complex
Acquisition_1C.coherent_integration_time_ms=1
Acquisition_1C.pfa=0.01
Acquisition_1C.doppler_max=5000
Acquisition_1C.doppler_step=250
Acquisition_1C.max_dwells=1
Tracking_1C.implementation=GPS_L1_CA_DLL_PLL_Tracking
Tracking_1C.item_type=gr_complex
Tracking_1C.pll_bw_hz=30.0
Tracking_1C.dll_bw_hz=2.0
Tracking_1C.early_late_space_chips=0.5
TelemetryDecoder_1C.implementation=GPS_L1_CA_Telemetry_Decoder
Observables.implementation=Hybrid_Observables
PVT.implementation=RTKLIB_PVT
PVT.positioning_mode=Single
{models}PVT.output_rate_ms={output_rate_ms}
PVT.display_rate_ms={display_rate_ms}
PVT.output_path={out}
"""
