"""Sunshine over time: hours of direct sun, cast-shadow frequency and beam incidence per cell
over many suns, accumulated on the device (kernels/sunshine.cl; docs/solar.md); and at one
site along the geodesics (:mod:`oclshade.sunshine.site`)."""
from .accumulate import (DEFAULT_AZIMUTHS, MAX_SECONDS, METHODS, OUTPUTS, SunshineCaster, SunshineMaps,
                         daylight)
from .site import SiteSunshine, site_sunshine
from .steps import TimeSteps, parse_step, time_steps

__all__ = ["DEFAULT_AZIMUTHS", "MAX_SECONDS", "METHODS", "OUTPUTS", "SiteSunshine", "SunshineCaster", "SunshineMaps",
           "TimeSteps", "daylight", "parse_step", "site_sunshine", "time_steps"]
