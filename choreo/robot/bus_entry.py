"""The ``bus:`` block of robot.yaml read into ``BusSettings``: port, timeout, retries, echo,
supply and GPIO direction lines."""

from __future__ import annotations

from choreo.bus.settings import MAX_RETRIES, MAX_TIMEOUT_MS, BusSettings
from choreo.core.file_shape import choices, mapping_shape
from choreo.core.yaml_source import Entry, Node, Reader

# The keys of the block and the echo modes, from the JSON Schema (the file's one description).
BUS = mapping_shape("robot", "#/properties/bus")  # the baud rate is always 115200
ECHO_MODES = choices("robot", "#/properties/bus/properties/echo")


def read_bus(reader: Reader, entry: Entry) -> BusSettings:
    fields = reader.fields(entry.value, "bus", BUS.keys) or {}
    # A refused value is reported (so the robot is refused too); its default stands in for it.
    default = BusSettings()
    port = default.port
    if "port" in fields:
        port = reader.string(fields["port"].value, "bus: port", optional=True)
    timeout_ms = None
    if "timeout_ms" in fields:
        timeout_ms = reader.number(
            fields["timeout_ms"].value,
            "bus: timeout_ms",
            low=0,
            high=MAX_TIMEOUT_MS,
            low_open=True,
        )
    retries = None
    if "retries" in fields:
        retries = reader.integer(fields["retries"].value, "bus: retries", low=0, high=MAX_RETRIES)
    echo = None
    if "echo" in fields:
        echo = reader.choice(fields["echo"].value, "bus: echo", ECHO_MODES)
    supply_v = None
    if "supply_v" in fields:
        supply_v = reader.number(fields["supply_v"].value, "bus: supply_v", low=0, low_open=True)
    direction = None
    if "direction" in fields:
        direction = _read_direction(reader, fields["direction"].value)
    return BusSettings(
        port=port,
        timeout_s=default.timeout_s if timeout_ms is None else timeout_ms / 1000,
        retries=default.retries if retries is None else retries,
        echo=default.echo if echo is None else echo,
        supply_v=supply_v,
        direction=direction,
    )


def _read_direction(reader: Reader, node: Node) -> str | None:
    from choreo.bus.transports.direction import (
        parse_direction,  # no GPIO library is imported by this
    )

    text = reader.string(node, "bus: direction", optional=True)
    if text is not None:
        try:
            parse_direction(text)
        except ValueError as error:
            reader.report(node, f"bus: direction: {error}")
            return None
    return text
