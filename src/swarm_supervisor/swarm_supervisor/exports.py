"""Lazy public faces for the sub-packages (:func:`mona_controller.exports.lazy_exports`, at
the bottom of the packages so that every package's faces share it), and the old names of
moved modules (:func:`mona_controller.exports.moved_modules`)."""

from mona_controller.exports import lazy_exports, moved_modules

__all__ = ['lazy_exports', 'moved_modules']
