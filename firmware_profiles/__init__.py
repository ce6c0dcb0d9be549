"""The shipped firmware profiles (*.yaml) and the CAN database (can-v1.dbc).

This folder installs as the package hand_service.firmware_profiles (see setup.py), so the
profiles are found through importlib.resources wherever the project is installed; the code
reads them as files (hand_service.config.profile.PROFILE_DIR), nothing here to import.
"""
