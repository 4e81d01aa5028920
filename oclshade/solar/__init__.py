"""Sun positions from date, time and place: NREL's Solar Position Algorithm
(``sun_position``), and ``oclshade.Sun`` objects for a list of datetimes (``suns_at``).
Conventions: the table in ``oclshade.solar.position``'s docstring."""
from .position import SunPosition, delta_t_estimate, refraction_correction, sun_position, suns_at

__all__ = ["SunPosition", "delta_t_estimate", "refraction_correction", "sun_position", "suns_at"]
