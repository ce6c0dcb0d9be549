"""What pyproject.toml cannot say (the metadata is there): cffi_modules, and the package list.

firmware_profiles/ stays at the repository root (docs and users name firmware_profiles/sim.yaml)
and installs as the package hand_service.firmware_profiles with its YAML profiles and DBC, so
hand_service.config.profile finds it through importlib.resources in a wheel and in the editable
install alike (setuptools' editable finder maps the package to the folder). A package mapped to
another folder cannot be found by [tool.setuptools.packages.find], hence the list here.
"""

from setuptools import find_packages, setup

PROFILES = "hand_service.firmware_profiles"
VIEW_STATIC = "hand_service.view.static"  # the live view's page: a data-only package

setup(
    cffi_modules=["rtcore/_build.py:ffibuilder", "hand_service/firmware/_build.py:ffibuilder"],
    packages=[*find_packages(include=["rtcore", "rtcore.*", "hand_service", "hand_service.*"]), PROFILES,
              VIEW_STATIC],
    package_dir={PROFILES: "firmware_profiles"},
    package_data={PROFILES: ["*.yaml", "*.dbc"], VIEW_STATIC: ["*"]},
)
