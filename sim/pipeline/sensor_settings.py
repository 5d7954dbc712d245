"""A case's sensor settings as text: ``key=value,...`` as given, or a sensor settings file's tables (the layout of
``models/sensors/<robot>.toml``: ``[sensors]`` and ``[lidar]``) as that text, so a case records the numbers, not the
file (``--sensors FILE`` on the command line, ``Case(sensors=PATH)`` from Python)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planning.errors import ConfigError, option


def _sensor_file(text: str | None) -> dict[str, dict[str, Any]] | None:
    """The tables of ``--sensors FILE`` (:func:`sim.physics.sensors.read_sensor_file`); None when ``text`` is
    ``key=value,...`` or empty.

    Raises:
        ConfigError: An unreadable file, one with neither a [sensors] nor a [lidar] table or with anything
            else, or a bad sensor key or value in it.
    """
    path = Path(text or "")
    if not text or "=" in text or not (path.suffix == ".toml" or path.exists()):
        return None
    from sim.physics.sensors import read_sensor_file

    tables = read_sensor_file(path)
    if "estimator" in tables:
        raise ConfigError(
            f"{option('sensors', str(path))}: its [estimator] table is a robot's own (its odometry's noise): give it "
            "in the sensor settings file the robot is registered with (docs/how-to/new-robot.md), or remove it here"
        )
    return tables


def sensor_overrides(text: str | None) -> str:
    """``--sensors``: ``key=value,...`` as given, or a TOML file's ``[sensors]`` table as that text (its
    ``[lidar]`` table is :func:`lidar_overrides`').

    Raises:
        ConfigError: As :func:`_sensor_file`.
    """
    tables = _sensor_file(text)
    if tables is None:
        return text or ""
    return ",".join(f"{k}={v}" for k, v in tables.get("sensors", {}).items())


def lidar_overrides(sensors: str | None, lidar: str | None, localiser: str | None = None) -> str:
    """The scanner's settings as ``--lidar`` takes them: the ``[lidar]`` table of a ``--sensors FILE`` (the
    layout of ``models/sensors/<robot>.toml``), then ``--lidar key=value,...`` over it.

    Raises:
        ConfigError: A bad key or value in the file's ``[lidar]`` table (naming the file and the field) or
            in ``--lidar``; a ``[lidar]`` table with ``--localiser fixes``, which takes no scan.
    """
    table = (_sensor_file(sensors) or {}).get("lidar")
    if table is None:
        return lidar or ""
    if localiser == "fixes":
        raise ConfigError(
            f"{sensors}: table [lidar]: --localiser fixes takes no scan, so the scanner's settings would be ignored; "
            "remove the [lidar] table from the file, or use --localiser amcl"
        )
    from sim.physics.keyvalue import parse_pairs
    from sim.physics.lidar import EXAMPLE, LIMITS, LidarProfile

    for key, value in table.items():
        if key not in LIMITS:
            raise ConfigError(f"{sensors}: field '[lidar] {key}': unknown key; the lidar keys are {', '.join(LIMITS)}")
        try:
            LidarProfile(**{key: value})
        except ConfigError as exc:
            raise ConfigError(f"{sensors}: field '[lidar] {key}': {exc}") from exc
    given = parse_pairs(lidar or "", option("lidar", lidar or ""), LIMITS, EXAMPLE)
    return ",".join(f"{k}={v}" for k, v in ({k: str(v) for k, v in table.items()} | given).items())
