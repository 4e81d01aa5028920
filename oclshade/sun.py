"""Sun positions: gdaldem words (azimuth clockwise from north, elevation above
the horizon, degrees) and their exact direction vectors."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence, Union

import numpy as np

DEFAULT_AZIMUTH = 315.0
DEFAULT_ELEVATION = 45.0


def sincos_degrees(angle: float) -> tuple[float, float]:
    """(sin, cos) of an angle in degrees, exact at multiples of 90 degrees (and
    of equal magnitude at odd multiples of 45), so that azimuths 0/90/180/270
    give rays exactly along the grid and 45/135/... exactly diagonal ones."""
    a = math.fmod(angle, 360.0)
    if a < 0.0:
        a += 360.0
        if a == 360.0:  # a tiny negative angle rounds up to 360: it is north, not a diagonal
            a = 0.0
    exact = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}
    if a in exact:
        return exact[a]
    if a % 45.0 == 0.0:  # odd multiples of 45: |sin| == |cos| exactly, diagonals stay diagonal
        r = math.sqrt(0.5)
        return (r if a < 180.0 else -r), (r if a in (45.0, 315.0) else -r)
    r = math.radians(a)
    return math.sin(r), math.cos(r)


@dataclass(frozen=True)
class Sun:
    azimuth: float = DEFAULT_AZIMUTH      # degrees clockwise from north
    elevation: float = DEFAULT_ELEVATION  # degrees above the horizon

    def __post_init__(self) -> None:
        for name in ("azimuth", "elevation"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"sun {name} must be a finite number of degrees, got {v!r}")
        if not -90.0 <= self.elevation <= 90.0:
            raise ValueError(f"sun elevation must be in [-90, 90] degrees, got {self.elevation!r}")

    @property
    def below_horizon(self) -> bool:
        """At or below the horizon: every cell is in shadow, no traversal."""
        return self.elevation <= 0.0

    @property
    def at_zenith(self) -> bool:
        """Straight overhead: nothing casts a shadow, no traversal."""
        return self.elevation >= 90.0

    def vector(self) -> tuple[float, float, float]:
        """Unit vector towards the sun in (east, north, up)."""
        sa, ca = sincos_degrees(self.azimuth)
        se, ce = sincos_degrees(self.elevation)
        return sa * ce, ca * ce, se

    def ray(self, dx: float, dy: float) -> tuple[float, float, float]:
        """(ux, uy, w): cells per metre along x (east) and y (south, rows), and
        the rise per horizontal metre tan(elevation).

        Rounded to float32 (subnormals to 0) so that the kernels and the
        float64 reference trace the very same ray.
        """
        sa, ca = sincos_degrees(self.azimuth)
        se, ce = sincos_degrees(self.elevation)
        w = 1.0 if self.elevation == 45.0 else (se / ce if ce > 0.0 else math.inf)
        return _float32(sa / dx), _float32(-ca / dy), _float32(w)


def _float32(value: float) -> float:
    """value rounded to the nearest float32; subnormals (flushed by many devices) become 0."""
    v = float(np.float32(value))
    return 0.0 if abs(v) < float(np.finfo(np.float32).tiny) else v


SunLike = Union[Sun, Sequence[float]]


def as_sun(value: SunLike) -> Sun:
    if isinstance(value, Sun):
        return value
    try:
        az, alt = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"a sun must be Sun(azimuth, elevation) or an (azimuth, elevation) pair, got {value!r}") from None
    return Sun(float(az), float(alt))


def as_suns(values: SunLike | Iterable[SunLike]) -> list[Sun]:
    """One sun or many: a Sun, an (az, alt) pair, or an iterable of those."""
    if isinstance(values, Sun):
        return [values]
    seq = list(values)  # type: ignore[arg-type]
    if len(seq) == 2 and all(isinstance(v, (int, float)) for v in seq):
        return [as_sun(seq)]
    if not seq:
        raise ValueError("suns must not be empty")
    return [as_sun(v) for v in seq]
