"""Shim for cffi_modules, which setuptools only takes here; metadata is in pyproject.toml."""

from setuptools import setup

setup(cffi_modules=["rtcore/_build.py:ffibuilder"])
