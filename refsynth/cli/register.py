"""TEMPORARY shim: the `register` subcommand moves here from refsynth.registration."""

from refsynth.registration.laser_camera import add_register_parser  # noqa: F401
