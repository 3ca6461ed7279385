"""Maximally Stable Extremal Regions (Matas et al. 2002) in linear time (Nistér & Stewénius 2008).

``detect(image, **params)`` takes a 2-D ``uint8`` array (any strides) and returns a list of
:class:`Region` objects: dark regions first, then bright, each by its threshold level counted
from its own side (dark regions by ascending ``level``, bright ones by descending ``level``) and
then by the row and column of its first pixel. ``preset(name)`` gives the parameters of
``"opencv"`` (OpenCV's ``MSER_create()`` defaults) and ``"larsson2009"`` (the thesis setting).

``detect(image, opencv_compatible=True)`` reproduces OpenCV 4.x's ``MSER.detectRegions`` on grey
images: the regions' pixel sets are the same as OpenCV's with the same parameters.
"""

from ._visguide import Region, detect, preset

PRESETS = ("opencv", "larsson2009")

__all__ = ["PRESETS", "Region", "detect", "preset"]
