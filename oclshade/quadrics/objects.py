"""Quadric objects in the world (x east, y north, z up; metres).

>>> Quadric.sphere((500, -800, 240), 40, Material("mirror"))
>>> Quadric.cylinder((300, -200, 60), radius=10, height=120)          # axis up by default
>>> Quadric.paraboloid((0, 0, 5), radius=30, height=8, axis=(0, 0.5, 1))

Shapes (the float64 twin :mod:`oclshade.reference.quadrics` has the equations): the
``frame`` is R (columns: local x, y, z axes in the world), local z = ``axis``, local x the
east direction made perpendicular to it (north when the axis points east or west);
``radii`` = S = (a, b, c) scale the unit shape:

===========  ===========================  =========================================================
kind         radii                        centre
===========  ===========================  =========================================================
sphere       (r, r, r)                    the centre
ellipsoid    (a, b, c) along local x, y,  the centre
             z (east, north, up for the
             default axis)
cylinder     (r, r, height / 2)           the middle of its axis; closed by two flat caps
paraboloid   (r, r, height)               the vertex (bottom of the open bowl); the rim, radius
                                          r, is ``height`` along the axis
===========  ===========================  =========================================================
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..envmap.materials import Material

KINDS = ("sphere", "ellipsoid", "cylinder", "paraboloid")
#: the kernel's shape code per kind (kernels/quadric.cl)
KIND_CODE = {"sphere": 0, "ellipsoid": 0, "cylinder": 1, "paraboloid": 2}


def _vector(name: str, value: object) -> np.ndarray:
    v = np.asarray(value, float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be 3 finite numbers (x east, y north, z up), got {value!r}")
    return v


def frame_from_axis(axis: object) -> np.ndarray:
    """R (3x3, columns local x, y, z): z along ``axis``, x east made perpendicular to it."""
    z = _vector("axis", axis)
    norm = np.linalg.norm(z)
    if norm == 0.0:
        raise ValueError("axis must be a non-zero vector")
    z = z / norm
    for ref in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        x = ref - (ref @ z) * z
        if np.linalg.norm(x) > 1e-6:
            break
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], 1)


@dataclass(frozen=True)
class Quadric:
    """One quadric: ``kind`` in :data:`KINDS`, ``centre``, ``radii`` (see the module doc),
    ``axis`` (local z, default up) and a :class:`~oclshade.envmap.materials.Material`."""

    kind: str
    centre: np.ndarray
    radii: np.ndarray
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    material: Material = Material()

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        object.__setattr__(self, "centre", _vector("centre", self.centre))
        radii = np.asarray(self.radii, float).reshape(-1)
        if radii.shape != (3,) or not np.all(np.isfinite(radii)) or radii.min() <= 0.0:
            raise ValueError(f"radii must be 3 positive finite lengths, got {self.radii!r}")
        if self.kind == "sphere" and not (radii[0] == radii[1] == radii[2]):
            raise ValueError(f"a sphere has one radius, got radii {self.radii!r}")
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "axis", _vector("axis", self.axis))
        frame_from_axis(self.axis)
        if not isinstance(self.material, Material):
            raise TypeError(f"material must be an oclshade Material, got {type(self.material).__name__}")

    @classmethod
    def sphere(cls, centre: object, radius: float, material: Material = Material()) -> "Quadric":
        return cls("sphere", centre, [radius] * 3, material=material)

    @classmethod
    def ellipsoid(cls, centre: object, radii: object, axis: object = (0.0, 0.0, 1.0),
                  material: Material = Material()) -> "Quadric":
        return cls("ellipsoid", centre, radii, axis, material)

    @classmethod
    def cylinder(cls, centre: object, radius: float, height: float, axis: object = (0.0, 0.0, 1.0),
                 material: Material = Material()) -> "Quadric":
        return cls("cylinder", centre, [radius, radius, 0.5 * height], axis, material)

    @classmethod
    def paraboloid(cls, vertex: object, radius: float, height: float, axis: object = (0.0, 0.0, 1.0),
                   material: Material = Material()) -> "Quadric":
        return cls("paraboloid", vertex, [radius, radius, height], axis, material)

    @property
    def frame(self) -> np.ndarray:
        return frame_from_axis(self.axis)

    @property
    def bound(self) -> tuple[np.ndarray, float]:
        """(centre, radius) of a world sphere holding the shape."""
        a, b, c = self.radii
        if self.kind in ("sphere", "ellipsoid"):
            return self.centre.copy(), float(max(a, b, c))
        if self.kind == "cylinder":
            return self.centre.copy(), float(np.hypot(max(a, b), c))
        return self.centre + 0.5 * c * self.frame[:, 2], float(np.hypot(max(a, b), 0.5 * c))
