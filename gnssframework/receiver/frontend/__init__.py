"""Front-end sample sources: sample formats (a plugin kind), SigMF metadata, block streaming."""

from .recording import Recording, RecordingInfo, open_recording
from .source import SampleSource
from .synthetic import SatelliteSignal, synthesize_samples
from .writer import write_recording

__all__ = [
    "SampleSource",
    "Recording",
    "RecordingInfo",
    "open_recording",
    "write_recording",
    "SatelliteSignal",
    "synthesize_samples",
]
