"""Materials of scene objects and their condition vectors (paper 002's static optimisation).

=========  ===================================================================  =====================
kind       colour of a sample (linear; E = the environment in the reflection    condition vector
           direction R, D = compose's diffuse light: sun x shadow + sky x AO)
=========  ===================================================================  =====================
diffuse    colour x D                                                           (none: no reflection)
mirror     colour x E                                                           REFLECT
glossy     (1 - F) colour x D + F E, F = F0 + (1 - F0)(1 - cos)^5 (Schlick,     REFLECT FRESNEL
           cos = -U . N, F0 = ``fresnel``)
=========  ===================================================================  =====================

``roughness`` > 0 (mirror or glossy) adds ROUGH: E becomes the mean of the environment over
16 fixed directions spread evenly over a cone of half-angle ``roughness`` x 45 degrees
around R (a spiral, kernels/reflect.cl) instead of one lookup.  It is a blur, not a
microfacet lobe: no energy or shape claim beyond "a uniform cone".

Each distinct condition vector is one program built from kernels/reflect.cl by
:func:`oclshade.specialize.specialize`: a feature no object uses is not in any program.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

KINDS = ("diffuse", "mirror", "glossy")
#: the reflect.cl conditions a material can switch on
CONDITIONS = ("REFLECT", "FRESNEL", "ROUGH")
#: roughness 1 is a cone of this half-angle (degrees)
MAX_CONE = 45.0
DEFAULT_COLOUR = {"diffuse": (0.8, 0.8, 0.8), "mirror": (1.0, 1.0, 1.0), "glossy": (0.8, 0.8, 0.8)}


@dataclass(frozen=True)
class Material:
    """A surface: ``kind`` in :data:`KINDS`; ``colour`` linear RGB in [0, 1] (albedo, or a
    mirror's reflectance; default per kind); ``roughness`` in [0, 1]; ``fresnel`` F0 in
    [0, 1] (glossy only)."""

    kind: str = "diffuse"
    colour: tuple[float, float, float] | None = None
    roughness: float = 0.0
    fresnel: float = 0.04

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"material must be one of {', '.join(KINDS)}, got {self.kind!r}")
        colour = DEFAULT_COLOUR[self.kind] if self.colour is None else self.colour
        c = np.asarray(colour, float).reshape(-1)
        if c.shape != (3,) or not np.all(np.isfinite(c)) or c.min() < 0.0 or c.max() > 1.0:
            raise ValueError(f"colour must be 3 linear RGB values in [0, 1], got {colour!r}")
        object.__setattr__(self, "colour", tuple(float(v) for v in c))
        for name in ("roughness", "fresnel"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not 0.0 <= float(v) <= 1.0:
                raise ValueError(f"{name} must be a number in [0, 1], got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.kind == "diffuse" and self.roughness > 0.0:
            raise ValueError("roughness applies to mirror and glossy materials, not diffuse")

    @property
    def conditions(self) -> frozenset[str]:
        """The condition vector of kernels/reflect.cl this material needs (empty: diffuse)."""
        if self.kind == "diffuse":
            return frozenset()
        return frozenset({"REFLECT"} | ({"FRESNEL"} if self.kind == "glossy" else set())
                         | ({"ROUGH"} if self.roughness > 0.0 else set()))

    @property
    def cone(self) -> float:
        """tan of the blur cone's half-angle (0: a sharp reflection)."""
        return math.tan(math.radians(MAX_CONE * self.roughness))
