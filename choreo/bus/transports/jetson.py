"""The direction presets on a Jetson: header pins to gpiod chip and line, per Jetson model.

The vendors' Jetson code (JetHexa, AiNex) names its two enable lines in Jetson.GPIO's BCM mode:
Raspberry-Pi-style numbers for pins of the 40-pin header. On a Raspberry Pi those numbers are the
line offsets on ``gpiochip0``; on a Jetson they are not, and the header pin's chip and line differ
per model. The table below is NVIDIA's own, from Jetson.GPIO
(``lib/python/Jetson/GPIO/gpio_pin_data.py``: line offset inside the chip, chip label, BOARD pin,
BCM pin), for the BCM numbers the presets use; the model is told by the device tree's
``compatible`` strings, as Jetson.GPIO does. A Jetson not in the table is refused with the header
pins to look up.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from choreo.errors import ChoreoError

DEVICE_TREE_COMPATIBLE = Path("/proc/device-tree/compatible")
BCM_TO_HEADER_PIN = {4: 7, 17: 11, 19: 35, 26: 37, 27: 13}  # the Pi header's layout


@dataclass(frozen=True)
class HeaderLine:
    chip: str  # the gpiochip's label
    offset: int  # the line inside that chip


# Jetson.GPIO: compatible strings of each model (compats_*).
JETSON_COMPATIBLES = {
    "Jetson Nano": ("nvidia,p3450-0000", "nvidia,p3450-0002", "nvidia,jetson-nano"),
    "Jetson TX1": ("nvidia,p2371-2180", "nvidia,jetson-cv"),
    "Jetson TX2": (
        "nvidia,p2771-0000",
        "nvidia,p2771-0888",
        "nvidia,p3489-0000",
        "nvidia,lightning",
        "nvidia,quill",
        "nvidia,storm",
    ),
    "Jetson TX2 NX": ("nvidia,p3509-0000+p3636-0001",),
    "Jetson AGX Xavier": (
        "nvidia,p2972-0000",
        "nvidia,p2972-0006",
        "nvidia,jetson-xavier",
        "nvidia,galen-industrial",
        "nvidia,jetson-xavier-industrial",
    ),
    "Clara AGX Xavier": ("nvidia,e3900-0000+p2888-0004",),
    "Jetson Xavier NX": (
        "nvidia,p3509-0000+p3668-0000",
        "nvidia,p3509-0000+p3668-0001",
        "nvidia,p3449-0000+p3668-0000",
        "nvidia,p3449-0000+p3668-0001",
        "nvidia,p3449-0000+p3668-0003",
    ),
    "Jetson AGX Orin": tuple(
        f"nvidia,p3737-0000+p3701-{sku}" for sku in ("0000", "0004", "0008", "0005", "0001")
    ),
    "Jetson Orin NX / Orin Nano": tuple(
        f"nvidia,{carrier}+p3767-{sku}{super_}"
        for carrier in ("p3509-0000", "p3768-0000")
        for sku in ("0000", "0001", "0003", "0004", "0005")
        for super_ in ("", "-super")
    ),
    "Jetson Thor": (
        "nvidia,p3971-0050+p3834-0005",
        "nvidia,p3971-0080+p3834-0008",
        "nvidia,p3971-0089+p3834-0008",
        "nvidia,p4071-0000+p3834-0008",
    ),
}


def _lines(chip: str, **by_bcm: tuple[str, int] | int) -> dict[int, HeaderLine]:
    """BCM number -> line; an int is a line of ``chip``, a pair names another chip."""
    return {
        int(bcm[3:]): HeaderLine(*line) if isinstance(line, tuple) else HeaderLine(chip, line)
        for bcm, line in by_bcm.items()
    }


# Jetson.GPIO's *_PIN_DEFS rows for header pins 7, 11, 13, 35, 37 (BCM 4, 17, 27, 19, 26).
HEADER_LINES = {
    "Jetson Nano": _lines("tegra-gpio", bcm4=216, bcm17=50, bcm27=14, bcm19=76, bcm26=12),
    "Jetson TX1": _lines("tegra-gpio", bcm4=216, bcm17=162, bcm27=38, bcm19=8, bcm26=187),
    "Jetson TX2": _lines("tegra-gpio", bcm4=76, bcm17=146, bcm27=77, bcm19=75, bcm26=68),
    "Jetson TX2 NX": _lines(
        "tegra-gpio-aon",
        bcm4=("tegra-gpio", 76),
        bcm17=28,
        bcm27=17,
        bcm19=("tegra-gpio", 75),
        bcm26=19,
    ),
    "Jetson AGX Xavier": _lines(
        "tegra194-gpio", bcm4=106, bcm17=112, bcm27=108, bcm19=54, bcm26=("tegra194-gpio-aon", 1)
    ),
    "Clara AGX Xavier": _lines(
        "tegra194-gpio", bcm4=106, bcm17=112, bcm27=96, bcm19=54, bcm26=("tegra194-gpio-aon", 1)
    ),
    "Jetson Xavier NX": _lines(
        "tegra194-gpio", bcm4=118, bcm17=112, bcm27=149, bcm19=130, bcm26=151
    ),
    "Jetson AGX Orin": _lines(
        "tegra234-gpio", bcm4=106, bcm17=112, bcm27=108, bcm19=53, bcm26=("tegra234-gpio-aon", 3)
    ),
    "Jetson Orin NX / Orin Nano": _lines(
        "tegra234-gpio", bcm4=144, bcm17=112, bcm27=122, bcm19=53, bcm26=124
    ),
    "Jetson Thor": _lines(
        "tegra264-gpio-main",
        bcm4=86,
        bcm17=92,
        bcm27=88,
        bcm19=24,
        bcm26=("tegra264-gpio-aon", 3),
    ),
}


def read_compatibles(path: Path = DEVICE_TREE_COMPATIBLE) -> list[str]:
    """The device tree's compatible strings ([] on a PC)."""
    try:
        return [c for c in path.read_bytes().decode(errors="replace").split("\0") if c]
    except OSError:
        return []


def jetson_model(compatibles: list[str]) -> str | None:
    """The Jetson model these compatible strings name; "" for an NVIDIA board not in the table;
    None when this is no Jetson."""
    for model, known in JETSON_COMPATIBLES.items():
        if any(c in known for c in compatibles):
            return model
    return "" if any(c.startswith("nvidia,") for c in compatibles) else None


def resolve_preset(name: str, rx_bcm: int, tx_bcm: int, compatibles: list[str]):
    """The (rx, tx, chip label) lines of a preset's BCM-numbered pins on this Jetson; None when
    this is no Jetson (the numbers are then the Pi's line offsets). ChoreoError when the model
    is unknown or its two lines are on different chips, saying what to pass instead."""
    model = jetson_model(compatibles)
    if model is None:
        return None
    pins = (
        f"header pins {BCM_TO_HEADER_PIN[rx_bcm]} (RX_CON, BCM {rx_bcm}) and "
        f"{BCM_TO_HEADER_PIN[tx_bcm]} (TX_CON, BCM {tx_bcm})"
    )
    explicit = (
        "find their chip and lines with `gpioinfo` and pass --direction rx=N,tx=N,chip=CHIP "
        "(robot.yaml: bus: direction:)"
    )
    if not model:
        raise ChoreoError(
            f"direction preset {name!r} on a Jetson choreo has no pin table for "
            f"({', '.join(compatibles[:2])}): the preset's lines are {pins}; {explicit}"
        )
    rx, tx = HEADER_LINES[model][rx_bcm], HEADER_LINES[model][tx_bcm]
    if rx.chip != tx.chip:
        raise ChoreoError(
            f"direction preset {name!r} on a {model}: {pins} are line {rx.offset} of "
            f"{rx.chip} and line {tx.offset} of {tx.chip}, and choreo switches both enable "
            "lines on one chip: direction control cannot drive this pair"
        )
    return rx.offset, tx.offset, rx.chip
