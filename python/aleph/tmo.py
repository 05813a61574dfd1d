"""The tone-reproduction operators by their papers, each a thin wrapper of
:func:`aleph.tonemap` taking linear RGB ``(H, W, 3)`` (``luminance_scale`` cd/m² per unit) and
returning display-linear RGB in [0, 1]. Keyword options are :func:`aleph.tonemap`'s
(``luminance_scale``, ``ppd``, ``adaptation``, ``display_max``, ``display_ambient``).

- :func:`tumblin_rushmeier93`: Tumblin & Rushmeier 1993, "Tone Reproduction for Realistic
  Images", IEEE CG&A 13(6) (brightness matching, Stevens & Stevens).
- :func:`ferwerda96`: Ferwerda, Pattanaik, Shirley & Greenberg 1996, "A Model of Visual
  Adaptation for Realistic Image Synthesis", SIGGRAPH (threshold matching, rods and cones).
- :func:`ward_larson97`: Ward Larson, Rushmeier & Piatko 1997, "A Visibility Matching Tone
  Reproduction Operator for High Dynamic Range Scenes", IEEE TVCG 3(4) (histogram adjustment).
- :func:`pattanaik00`: Pattanaik, Tumblin, Yee & Greenberg 2000, "Time-Dependent Visual
  Adaptation for Fast Realistic Image Display", SIGGRAPH (static form).
- :func:`reinhard02`: Reinhard, Stark, Shirley & Ferwerda 2002, "Photographic Tone Reproduction
  for Digital Images", SIGGRAPH (global operator).
- :func:`exposure`: constant scaling.
"""

from typing import Any

import numpy as np

from . import tonemap


def tumblin_rushmeier93(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Tumblin & Rushmeier 1993 (IEEE CG&A 13(6)); see the module docs."""
    return tonemap(rgb, "tr", **kw)


def ferwerda96(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Ferwerda, Pattanaik, Shirley & Greenberg 1996 (SIGGRAPH); see the module docs."""
    return tonemap(rgb, "fpsg", **kw)


def ward_larson97(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Ward Larson, Rushmeier & Piatko 1997 (IEEE TVCG 3(4)); see the module docs."""
    return tonemap(rgb, "wrp", **kw)


def pattanaik00(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Pattanaik, Tumblin, Yee & Greenberg 2000 (SIGGRAPH), static; see the module docs."""
    return tonemap(rgb, "ptyg", **kw)


def reinhard02(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Reinhard, Stark, Shirley & Ferwerda 2002 (SIGGRAPH), global; see the module docs."""
    return tonemap(rgb, "reinhard", **kw)


def exposure(rgb: np.ndarray, **kw: Any) -> np.ndarray:
    """Constant scaling; see the module docs."""
    return tonemap(rgb, "exposure", **kw)


__all__ = [
    "exposure",
    "ferwerda96",
    "pattanaik00",
    "reinhard02",
    "tumblin_rushmeier93",
    "ward_larson97",
]
