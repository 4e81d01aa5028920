"""Sun positions from date, time and place: NREL's Solar Position Algorithm
(``sun_position``), ``oclshade.Sun`` objects for a list of datetimes (``suns_at``), and a
raster's site (``map_site``: its place, and true azimuths turned to its grid through its CRS), and
the sun over a whole map at a time, each cell's own to a tolerance (``sun_field``).
Conventions: the table in ``oclshade.solar.position``'s docstring."""
from .position import SunPosition, delta_t_estimate, refraction_correction, sun_position, suns_at
from .field import MapPlaces, map_places, sun_field
from .site import MapSite, map_site

__all__ = ["MapPlaces", "MapSite", "map_places", "sun_field", "SunPosition", "delta_t_estimate", "map_site", "refraction_correction", "sun_position",
           "suns_at"]
