"""Read and write energyscape records (sonar images from mimobeamform).

A record is a 96-byte little-endian header followed by float32 envelope
amplitudes data[n_elevation][n_azimuth][n_range]; a file holds records back
to back (filesink appends one per ping). Header:

    offset type     field
    0      char[8]  magic "SONARES1"
    8      uint32   header_size (96 for this version; data starts here)
    12     uint32   n_azimuth
    16     uint32   n_elevation
    20     uint32   n_range
    24     uint64   ping_index
    32     float64  azimuth_first (degrees)
    40     float64  azimuth_step (degrees; 0 if n_azimuth == 1)
    48     float64  elevation_first
    56     float64  elevation_step
    64     float64  range_first (m)
    72     float64  range_step (m)
    80     float64  velocity (m/s; NaN = maximum over Doppler hypotheses)
    88     int32    emitter (-1 = MIMO image over all emitters)
    92     uint32   reserved (0)

Angles follow the sensor frame of docs/CONTRACTS.md: azimuth from boresight
(+z) towards +x, elevation towards +y.
"""

import dataclasses
import math
import struct

import numpy as np

MAGIC = b"SONARES1"
HEADER = struct.Struct("<8sIIIIQdddddddiI")
HEADER_SIZE = HEADER.size  # 96


class EnergyscapeError(ValueError):
    """A file that is not a valid sequence of energyscape records."""


@dataclasses.dataclass
class Energyscape:
    """One energyscape: an image of envelope amplitude over angles and range.

    data has shape (n_elevation, n_azimuth, n_range), float32, linear.
    """

    ping_index: int
    azimuth_first: float
    azimuth_step: float
    elevation_first: float
    elevation_step: float
    range_first: float
    range_step: float
    velocity: float
    emitter: int
    data: np.ndarray

    @property
    def n_elevation(self):
        """Number of elevation rows."""
        return self.data.shape[0]

    @property
    def n_azimuth(self):
        """Number of azimuth columns."""
        return self.data.shape[1]

    @property
    def n_range(self):
        """Number of range bins."""
        return self.data.shape[2]

    @property
    def is_3d(self):
        """True when the image spans several elevations."""
        return self.n_elevation > 1

    @property
    def azimuth(self):
        """Azimuth of each column, degrees."""
        return self.azimuth_first + self.azimuth_step * np.arange(
            self.n_azimuth)

    @property
    def elevation(self):
        """Elevation of each row, degrees."""
        return self.elevation_first + self.elevation_step * np.arange(
            self.n_elevation)

    @property
    def range(self):
        """Range of each bin, metres."""
        return self.range_first + self.range_step * np.arange(self.n_range)

    def peak(self):
        """(azimuth deg, elevation deg, range m) of the brightest cell."""
        e, a, r = np.unravel_index(int(np.argmax(self.data)),
                                   self.data.shape)
        return (float(self.azimuth[a]), float(self.elevation[e]),
                float(self.range[r]))

    def to_bytes(self):
        """The record as stored in a file."""
        data = np.ascontiguousarray(self.data, dtype="<f4")
        if data.ndim != 3 or 0 in data.shape:
            raise EnergyscapeError("data must be a non-empty 3-D array "
                                   "(elevation, azimuth, range)")
        header = HEADER.pack(MAGIC, HEADER_SIZE, data.shape[1],
                             data.shape[0], data.shape[2], self.ping_index,
                             self.azimuth_first, self.azimuth_step,
                             self.elevation_first, self.elevation_step,
                             self.range_first, self.range_step,
                             self.velocity, self.emitter, 0)
        return header + data.tobytes()


def parse(buffer, origin="<bytes>"):
    """Parse every record of buffer; origin names it in error messages."""
    records = []
    offset = 0
    view = memoryview(buffer)
    while offset < len(view):
        where = f"{origin}: record {len(records)} at byte {offset}"
        if len(view) - offset < HEADER_SIZE:
            raise EnergyscapeError(
                f"{where}: truncated header ({len(view) - offset} of "
                f"{HEADER_SIZE} bytes)")
        (magic, header_size, n_az, n_el, n_r, ping, az0, daz, el0, del_,
         r0, dr, velocity, emitter, _reserved) = HEADER.unpack_from(view,
                                                                    offset)
        if magic != MAGIC:
            raise EnergyscapeError(
                f"{where}: bad magic {magic!r}, expected {MAGIC!r}")
        if header_size < HEADER_SIZE:
            raise EnergyscapeError(
                f"{where}: header_size {header_size} is below "
                f"{HEADER_SIZE}")
        if 0 in (n_az, n_el, n_r):
            raise EnergyscapeError(
                f"{where}: empty image ({n_az} azimuths x {n_el} "
                f"elevations x {n_r} ranges)")
        axes = (az0, daz, el0, del_, r0, dr)
        if not all(math.isfinite(v) for v in axes):
            raise EnergyscapeError(f"{where}: non-finite axis in header")
        n_values = n_az * n_el * n_r
        end = offset + header_size + 4 * n_values
        if end > len(view):
            raise EnergyscapeError(
                f"{where}: truncated record: needs {end - offset} bytes "
                f"({n_az} x {n_el} x {n_r} float32), {len(view) - offset} "
                f"left in the file")
        data = np.frombuffer(view, dtype="<f4", count=n_values,
                             offset=offset + header_size)
        records.append(Energyscape(
            ping_index=ping, azimuth_first=az0, azimuth_step=daz,
            elevation_first=el0, elevation_step=del_, range_first=r0,
            range_step=dr, velocity=velocity, emitter=emitter,
            data=data.reshape(n_el, n_az, n_r).astype(np.float32)))
        offset = end
    return records


def read(path):
    """Every record of an energyscape file, in order."""
    with open(path, "rb") as f:
        buffer = f.read()
    if not buffer:
        raise EnergyscapeError(f"{path}: empty file, no energyscape record")
    return parse(buffer, str(path))


def write(path, records):
    """Write records back to back (the inverse of read)."""
    with open(path, "wb") as f:
        for record in records:
            f.write(record.to_bytes())


def fan_xy(azimuth_deg, range_m):
    """Cartesian position in the horizontal fan: x = r sin az, y = r cos az.

    Boresight is +y (up in the picture), positive azimuth to the right.
    Broadcasts like numpy.
    """
    az = np.radians(azimuth_deg)
    return range_m * np.sin(az), range_m * np.cos(az)
