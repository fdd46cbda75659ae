"""The receiver's track as GeoJSON (``track.geojson``) and KML (``track.kml``).

GeoJSON (RFC 7946) is plain JSON: a FeatureCollection of one LineString feature through
every fix and one Point feature per fix, positions as ``[longitude, latitude, height]``
(RFC 7946 3.1.1: longitude first, WGS 84 degrees, the height in metres above the
ellipsoid), coordinates to 1e-9 degree (0.1 mm) and 1 mm. Each Point's properties are its
row of ``positions.csv`` (GPS week, time of week, velocity, satellites, DOPs) and its UTC
time (ISO 8601). KML 2.2 (OGC 07-147r2) is written with the standard library's
ElementTree: a Document with a LineString Placemark (``altitudeMode`` absolute: KML's
altitude is above the geoid, the height here above the ellipsoid, tens of metres apart)
and a Placemark per fix with its ``TimeStamp``; KML coordinates are ``lon,lat,alt`` too.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.weeks import gps_calendar
from .fixes import POSITION_COLUMNS, PositionTable

__all__ = ["track_geojson", "write_geojson", "write_kml"]

_KML_NS = "http://www.opengis.net/kml/2.2"


def _utc(table: PositionTable, k: int, leap_seconds: int) -> str:
    c = table.columns
    t = gps_calendar(int(c["gps_week"][k]), float(c["tow_s"][k]) - leap_seconds)
    return t.isoformat(timespec="milliseconds") + "Z"


def _position(table: PositionTable, k: int) -> list[float]:
    c = table.columns
    return [round(float(c["lon_deg"][k]), 9), round(float(c["lat_deg"][k]), 9), round(float(c["height_m"][k]), 3)]


def _checked(table: PositionTable) -> None:
    if len(table) == 0:
        raise ConfigError("table", "no fix: no track to write")
    if not set(POSITION_COLUMNS) <= set(table.columns):
        raise ConfigError("table", f"lacks {sorted(set(POSITION_COLUMNS) - set(table.columns))}")


def track_geojson(table: PositionTable, leap_seconds: int = 18, satellite_name=None) -> dict:
    """The GeoJSON FeatureCollection of ``table``'s fixes (see the module text). With
    ``satellite_name`` (a `multi_receive.SignalSet`'s ``rinex_satellite``, for fixes of
    several signals) the satellites used are named (``"satellites_used": ["G05", "E11"]``)
    instead of listed as ``prns_used``."""
    _checked(table)
    c = table.columns
    points = []
    for k in range(len(table)):
        props: dict[str, object] = {
            name: (
                int(c[name][k])
                if name in ("gps_week", "n_sats")
                else (None if not np.isfinite(c[name][k]) else round(float(c[name][k]), 9))
            )
            for name in POSITION_COLUMNS
            if name not in ("lat_deg", "lon_deg", "height_m")
        }
        props["time_utc"] = _utc(table, k, leap_seconds)
        if satellite_name is None:
            props["prns_used"] = [int(p) for p in table.used_prns[k]]
        else:
            props["satellites_used"] = [satellite_name(int(p)) for p in table.used_prns[k]]
        points.append(
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": _position(table, k)}, "properties": props}
        )
    line = {
        "type": "Feature",
        "geometry": {"type": "LineString", "coordinates": [_position(table, k) for k in range(len(table))]},
        "properties": {"name": "track", "fixes": len(table)},
    }
    return {"type": "FeatureCollection", "features": [line, *points]}


def write_geojson(path: str | Path, table: PositionTable, leap_seconds: int = 18, satellite_name=None) -> Path:
    """``track.geojson``: `track_geojson` as JSON."""
    path = Path(path)
    text = json.dumps(track_geojson(table, leap_seconds, satellite_name), indent=1, allow_nan=False)
    path.write_text(text + "\n")
    return path


def write_kml(
    path: str | Path, table: PositionTable, leap_seconds: int = 18, name: str = "gnssframework track"
) -> Path:
    """``track.kml``: the track and one placemark per fix (see the module text)."""
    _checked(table)
    ET.register_namespace("", _KML_NS)
    q = lambda tag: f"{{{_KML_NS}}}{tag}"  # noqa: E731
    root = ET.Element(q("kml"))
    doc = ET.SubElement(root, q("Document"))
    ET.SubElement(doc, q("name")).text = name
    coords = [",".join(f"{v}" for v in _position(table, k)) for k in range(len(table))]
    mark = ET.SubElement(doc, q("Placemark"))
    ET.SubElement(mark, q("name")).text = "track"
    line = ET.SubElement(mark, q("LineString"))
    ET.SubElement(line, q("altitudeMode")).text = "absolute"
    ET.SubElement(line, q("coordinates")).text = " ".join(coords)
    folder = ET.SubElement(doc, q("Folder"))
    ET.SubElement(folder, q("name")).text = "fixes"
    for k, xyz in enumerate(coords):
        fix = ET.SubElement(folder, q("Placemark"))
        ET.SubElement(ET.SubElement(fix, q("TimeStamp")), q("when")).text = _utc(table, k, leap_seconds)
        point = ET.SubElement(fix, q("Point"))
        ET.SubElement(point, q("altitudeMode")).text = "absolute"
        ET.SubElement(point, q("coordinates")).text = xyz
    ET.indent(root)
    path = Path(path)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path
