"""What is behind a port, found by listening and asking reads only (``choreo ports --probe``).

Nothing written here changes a servo or a board; each step is bounded in time:

1. listen at 1,000,000 baud for up to ``RRC_LISTEN_S``: an RRC board announces itself with a
   battery frame about once a second (nothing is sent);
2. at 9600 send the LOBOT controller's battery read: the controller answers with its voltage;
3. at 115200 send one broadcast ID read: servos on a raw LX bus answer (several at once collide,
   which still tells a bus is there).

The LOBOT's frames have no checksum, so it is asked before anything is sent at another baud
rate that it could take for part of a command; at the wrong baud rate the RRC board's frames
fail their CRC and LX packets their checksum (and their decoder drops a LOBOT frame's length).
Then the servo IDs are read where the transport can: ID reads one by one on the raw bus and the
RRC board, one multi-servo position read on the LOBOT controller.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from choreo.bus.protocol import BROADCAST_ID, Command, PacketDecoder, encode_request
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports import lobot, open_serial, raw, rrc
from choreo.errors import ChoreoError

RRC_LISTEN_S = 1.2  # the board's battery frame comes about once a second
RAW_ANSWER_S = 0.05  # a servo answers within a millisecond; USB adapters add up to 16 ms
LOBOT_ANSWER_S = 0.3  # C3's own wait for a read
SCAN_TIMEOUT_S = 0.02  # per ID: covers the RRC board's 5 ms servo timeout and USB latency
LOBOT_IDS = range(1, 253)  # one position-read frame: LEN = 3 + n must fit a byte


@dataclass(frozen=True)
class ProbeResult:
    """What answered on one port (``transport`` None: nothing did)."""

    device: str
    transport: str | None  # "RRC board", "raw LX bus", "LOBOT controller"
    port_string: str | None  # what to pass as --port
    servo_ids: tuple[int, ...] | None  # None: not readable through what was found
    battery_mv: int | None = None
    note: str = ""


def probe_port(device: str) -> ProbeResult:
    """Probe one serial device (or ``sim://`` URL); ``lobot://hid`` asks the HID controller.
    A port that cannot be opened is a result too, saying why."""
    try:
        return _probe(device)
    except ChoreoError as error:
        return ProbeResult(device, None, None, None, note=str(error))


def _probe(device: str) -> ProbeResult:
    if device.lower() == "lobot://hid":
        return _probe_lobot(device, device) or _nothing(device)
    battery = _listen_for_rrc(device)
    if battery is not None:
        port_string = _board_port(device, "rrc")
        return ProbeResult(
            device, "RRC board", port_string, _scan_ids(port_string, SCAN_TIMEOUT_S), battery
        )
    lobot_found = _probe_lobot(device, _board_port(device, "lobot"))
    if lobot_found is not None:
        return lobot_found
    answered = _raw_id_read(device)
    if answered is None:
        return _nothing(device)
    ids = (answered,) if answered != BROADCAST_ID else _scan_ids(device, SCAN_TIMEOUT_S)
    note = "" if answered != BROADCAST_ID else "several servos answered the broadcast at once"
    return ProbeResult(device, "raw LX bus", device, ids, note=note)


def _board_port(device: str, scheme: str) -> str:
    """The --port string of a board on ``device``: an emulator's URL already names its board."""
    return device if device.startswith("sim://") else f"{scheme}://{device}"


def _listen_for_rrc(device: str) -> int | None:
    """The battery voltage an RRC board announced within ``RRC_LISTEN_S``, or None."""
    with open_serial(device, RRC_LISTEN_S / 4, rrc.BAUDRATE, quiet_lines=True) as port:
        clock = getattr(port, "clock", None)
        now = clock.now if clock is not None else time.monotonic
        decoder, deadline_s = rrc.FrameDecoder(), now() + RRC_LISTEN_S
        while now() < deadline_s:
            port.timeout = max(deadline_s - now(), 0.001)
            for frame in decoder.feed(port.read(64)):
                battery = rrc.battery_mv(frame)
                if battery is not None:
                    return battery
    return None


def _raw_id_read(device: str) -> int | None:
    """The ID that answered a broadcast ID read; ``BROADCAST_ID`` when replies collided
    (bytes came, no clean reply); None when nothing answered."""
    request = encode_request(Command.ID_READ, BROADCAST_ID)
    with open_serial(device, RAW_ANSWER_S, raw.BAUDRATE) as port:
        port.reset_input_buffer()
        port.write(request)
        data = port.read(64)
    replies = [p for p in PacketDecoder().feed(data) if p.encode() != request]  # not our echo
    for reply in replies:
        if reply.command == Command.ID_READ and len(reply.params) == 1:
            return reply.params[0]
    leftover = data.replace(request, b"")
    return BROADCAST_ID if leftover else None


def _probe_lobot(device: str, port_string: str) -> ProbeResult | None:
    """The LOBOT controller and its servos, or None when no controller answered."""
    with ServoBus(port_string, timeout_s=LOBOT_ANSWER_S, retries=0) as bus:
        board = bus.backend
        if not isinstance(board, lobot.LobotBoard):  # an emulator URL naming another board
            return None
        battery = board.read_battery(LOBOT_ANSWER_S)
        if battery is None:
            return None
        found = board.read_positions(LOBOT_IDS, lobot.SERVO_READ_S) or {}
    note = "" if found else "no bus servo answered: a LeArm's LSC-6 board drives PWM servos"
    return ProbeResult(device, "LOBOT controller", port_string, tuple(sorted(found)), battery, note)


def _nothing(device: str) -> ProbeResult:
    return ProbeResult(
        device,
        None,
        None,
        None,
        note="nothing answered (no RRC battery frame, no LX reply, no LOBOT reply); a raw bus "
        "behind a Pi/Jetson HAT needs its direction lines: choreo scan --direction PRESET",
    )


def _scan_ids(port_string: str, timeout_s: float) -> tuple[int, ...]:
    with ServoBus(port_string, timeout_s=timeout_s, retries=0) as bus:
        return tuple(bus.scan(range(BROADCAST_ID), timeout_s=timeout_s))
