"""Lazy public faces for the sub-packages (:func:`mona_controller.exports.lazy_exports`, at
the bottom of the packages so that every package's faces share it)."""

from mona_controller.exports import lazy_exports

__all__ = ['lazy_exports']
