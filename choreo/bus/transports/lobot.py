"""``lobot://hid`` and ``lobot://PATH``: the LOBOT Bus Servo Controller of the xArm, over USB HID
(0483:5750) or its 9600-baud UART. (The LeArm's LSC-6 board shares the USB ID and the framing,
but drives PWM servos: it cannot read positions.)

Frames are ``55 55 LEN CMD PARAMS`` with LEN = len(PARAMS) + 2 and no checksum (a corrupted
frame is not detected). The basic command set: 03 moves several servos over one duration,
0F reads the battery, 14 unloads servos, 15 reads positions. There is no staging, no MOVE_STOP,
no per-servo voltage or temperature read: choreo refuses what needs them. To stop, choreo reads
where the servos are and commands them to stay there (the closest thing to MOVE_STOP it has);
servos whose position does not come back are held at the targets last commanded to them.
Over HID each frame goes out as one output report prefixed by report ID 0; input reports are 64
bytes, the frame at their start. How often the host may send a report is the endpoint's polling
interval, which no source gives for this board: ``lobot://hid?report_ms=N`` sets it (default
1 ms, an assumption; ST's Custom HID template, where this VID:PID comes from, polls every 32 ms).
See docs/transports.md.
"""

from __future__ import annotations

import functools
import logging
import urllib.parse
from collections.abc import Sequence
from dataclasses import dataclass, replace

from choreo.bus.framing import MORE, NOT_A_FRAME, ResyncDecoder
from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.bus.transports import (
    Attempt,
    BytePort,
    Capabilities,
    Connection,
    Direction,
    Link,
    open_serial,
    path_of,
    refuse_direction,
)
from choreo.core.clock import RealClock
from choreo.errors import PortError, UnsupportedByTransport

log = logging.getLogger(__name__)

BAUDRATE = 9600
HEADER = b"\x55\x55"
MOVE, BATTERY, UNLOAD, READ_POSITIONS = 0x03, 0x0F, 0x14, 0x15
HID_VID, HID_PID = 0x0483, 0x5750
HID_REPORT = 64
MAX_READS_PER_ATTEMPT = 4
SERVO_READ_S = 0.006  # the board reading one servo, with its reply timeout [assumed]

CAPABILITIES = Capabilities(
    transport="LOBOT controller",
    commands=frozenset(
        {Command.MOVE_TIME_WRITE, Command.LOAD_OR_UNLOAD_WRITE, Command.POS_READ, Command.ID_READ}
    ),
    staged_start=False,
    stop="no MOVE_STOP exists: choreo reads the servos' positions and commands them to stay there",
    load=False,
    host_byte_time_s=10 / BAUDRATE,
    move_frame_bytes=7,  # 55 55 LEN 03 n time:u16, then 3 bytes per servo
    forward_s_per_servo=10 * 10 / 115200,  # assumed like the RRC: one LX packet after another
)
DEFAULT_REPORT_MS = 1.0  # [assumed]; ST's Custom HID template polls every 32 ms
MAX_REPORT_MS = 255  # bInterval is one byte of milliseconds at full speed


def hid_capabilities(report_ms: float = DEFAULT_REPORT_MS) -> Capabilities:
    """Over HID a frame (at most one report) leaves on the next poll: ``report_ms`` apart."""
    return replace(CAPABILITIES, host_byte_time_s=report_ms / 1000 / HID_REPORT)


def encode_frame(command: int, params: bytes = b"") -> bytes:
    return HEADER + bytes((len(params) + 2, command)) + params


@dataclass(frozen=True)
class Frame:
    command: int
    params: bytes


class FrameDecoder(ResyncDecoder[Frame]):
    """Bytes to frames, resynchronising on ``55 55`` (no checksum to check). Never raises."""

    header = HEADER

    def frame_length(self, buf: bytearray) -> int:
        if len(buf) < 3:
            return MORE
        return 2 + buf[2] if buf[2] >= 2 else NOT_A_FRAME

    def frame(self, buf: bytearray, total: int) -> Frame:
        return Frame(buf[3], bytes(buf[4:total]))


def move_frame(moves: Sequence[tuple[int, int]], time_ms: int) -> bytes:
    params = bytes((len(moves),)) + time_ms.to_bytes(2, "little")
    for servo_id, pos_units in moves:
        params += bytes((servo_id,)) + pos_units.to_bytes(2, "little")
    return encode_frame(MOVE, params)


def unload_frame(servo_ids: Sequence[int]) -> bytes:
    return encode_frame(UNLOAD, bytes((len(servo_ids), *servo_ids)))


def read_positions_frame(servo_ids: Sequence[int]) -> bytes:
    return encode_frame(READ_POSITIONS, bytes((len(servo_ids), *servo_ids)))


def battery_frame() -> bytes:
    return encode_frame(BATTERY)


def positions(frame: Frame) -> dict[int, int]:
    """servo id -> position of a READ_POSITIONS reply (``n (id pos:int16)×n``)."""
    params = frame.params
    count = params[0] if params else 0
    found = {}
    for i in range(count):
        entry = params[1 + 3 * i : 4 + 3 * i]
        if len(entry) == 3:
            found[entry[0]] = int.from_bytes(entry[1:], "little", signed=True)
    return found


# --- the board ---------------------------------------------------------------------------------
def connect(
    url: str, timeout_s: float, direction: Direction | None = None, echo: object = None
) -> Connection:
    """The controller on ``lobot://hid`` or the UART ``lobot://PATH`` names (no echo on its
    link: ``echo`` is moot)."""
    if direction is not None:
        raise refuse_direction(url, CAPABILITIES)
    on = link(url)
    if _is_hid(url):
        port: BytePort = HidReportPort.open_first(timeout_s)
    else:
        port = open_serial(path_of(url), timeout_s, BAUDRATE)
    return Connection(port, on.backend_on(port), RealClock())


def link(url: str) -> Link:
    """The controller's frames; over HID, at the report interval ``lobot://hid?report_ms=N``
    gives."""
    if not _is_hid(url):
        return LINK
    capabilities = hid_capabilities(report_ms(url))
    return Link(capabilities, functools.partial(LobotBoard, capabilities=capabilities), move_frame)


def _is_hid(url: str) -> bool:
    return path_of(url).lower().split("?")[0] == "hid"


def report_ms(url: str) -> float:
    """``lobot://hid?report_ms=N``: the HID report interval, 1 to 255 ms (default 1)."""
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query, keep_blank_values=True)
    unknown = set(query) - {"report_ms"}
    text = query.get("report_ms", [str(DEFAULT_REPORT_MS)])[-1]
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if unknown or not 1 <= value <= MAX_REPORT_MS:
        raise PortError(
            f"{url}: expected lobot://hid or lobot://hid?report_ms=N with N the HID report "
            f"interval, 1 to {MAX_REPORT_MS} ms (e.g. 32)"
        )
    return value


def board_on(port: BytePort) -> LobotBoard:
    return LobotBoard(port)


class LobotBoard:
    """The LOBOT controller's commands on an open port (serial or :class:`HidReportPort`)."""

    def __init__(self, port: BytePort, capabilities: Capabilities = CAPABILITIES):
        self.port = port
        self.capabilities = capabilities
        self.bad_checksums = 0  # the controller checks the servos' replies itself
        self.decoder = FrameDecoder()
        self.last_targets: dict[int, int] = {}  # servo id -> the position last commanded

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        if command == Command.MOVE_TIME_WRITE:
            return self.move_many([(servo_id, fields["pos_units"])], fields["time_ms"])
        if command == Command.LOAD_OR_UNLOAD_WRITE and not fields["loaded"]:
            frame = unload_frame([servo_id])
            self.port.write(frame)
            return len(frame)
        raise UnsupportedByTransport(
            f"{getattr(self.port, 'name', 'lobot')}: the LOBOT controller cannot load (torque "
            "on) a servo; a move powers it again. "
            "To load without moving, connect the servos to the raw LX bus"
        )

    def send_many(self, command: Command, writes: Sequence[tuple[int, dict[str, int]]]) -> int:
        # One frame per write: over USB HID each write is one report, which holds one frame.
        return sum(self.send(command, servo_id, fields) for servo_id, fields in writes)

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        frame = move_frame(moves, time_ms)
        self.port.write(frame)
        self.last_targets.update(moves)
        return len(frame)

    def read_positions(self, servo_ids: Sequence[int], timeout_s: float) -> dict[int, int] | None:
        """Positions of the servos that answered; None if the board sent no reply.

        ``timeout_s`` is per servo, counted after the request and the whole reply have crossed
        the host link (at 9600 baud an 18-servo reply alone takes 61 ms)."""
        port, request = self.port, read_positions_frame(servo_ids)
        wanted = total = 5 + 3 * len(servo_ids)
        link_s = (len(request) + total) * self.capabilities.host_byte_time_s
        port.timeout = link_s + timeout_s * len(servo_ids)
        port.flush()  # a move frame may still be leaving: the timeout starts after it
        port.reset_input_buffer()
        self.decoder.reset()
        port.write(request)
        # A read cut short (Ctrl-C during a health read) is still answered by the board after
        # this request was sent: a reply naming other servos than asked is kept only until the
        # right one comes (the board answers in order; one with silent servos left out is the
        # last to come).
        latest = None
        for _ in range(MAX_READS_PER_ATTEMPT):
            data = port.read(wanted)
            for frame in self.decoder.feed(data):
                if frame.command == READ_POSITIONS:
                    latest = positions(frame)
                    if set(latest) == set(servo_ids):
                        return latest
            if len(data) < wanted:
                return latest
            wanted = self.decoder.bytes_to_complete(total)
        return latest

    def read_battery(self, timeout_s: float) -> int | None:
        """The board's supply voltage in mV (command 0F); None if it did not answer."""
        port, request = self.port, battery_frame()
        port.timeout = (len(request) + 6) * self.capabilities.host_byte_time_s + timeout_s
        port.flush()
        port.reset_input_buffer()
        self.decoder.reset()
        port.write(request)
        for frame in self.decoder.feed(port.read(6)):
            if frame.command == BATTERY and len(frame.params) == 2:
                return int.from_bytes(frame.params, "little")
        return None

    def request(self, command: Command, servo_id: int, timeout_s: float) -> Attempt:
        return Attempt(self._read(command, servo_id, timeout_s))

    def _read(self, command: Command, servo_id: int, timeout_s: float) -> dict[str, int] | None:
        """POS_READ; ID_READ is answered by a position read of that ID (a servo is there)."""
        if servo_id == BROADCAST_ID:
            raise UnsupportedByTransport(
                f"{getattr(self.port, 'name', 'lobot')}: the LOBOT controller cannot ask every "
                "servo at once; name the servo's ID, or connect the servos to the raw LX bus"
            )
        found = self.read_positions([servo_id], timeout_s) or {}
        if servo_id not in found:
            return None
        if command == Command.ID_READ:
            return {"servo_id": servo_id}
        return {"pos_units": found[servo_id]}

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        """Hold where they are: read the positions, move there at once (no MOVE_STOP exists).
        A servo whose position does not come back is held at its last commanded target, where
        it was going anyway."""
        found = self.read_positions(servo_ids, SERVO_READ_S) or {}
        unread = [i for i in servo_ids if i not in found]
        targets = {i: self.last_targets[i] for i in unread if i in self.last_targets}
        if targets:
            log.warning(
                "LOBOT controller: no position came back from servo(s) %s: held at their last "
                "commanded targets",
                ", ".join(map(str, sorted(targets))),
            )
        if lost := [i for i in unread if i not in targets]:
            log.error(
                "LOBOT controller: servo(s) %s neither answered nor were moved: not held",
                ", ".join(map(str, lost)),
            )
        if hold := {**targets, **found}:
            self.move_many(sorted(hold.items()), 0)


class HidReportPort:
    """The LOBOT controller's USB HID link with the read/write methods of a serial port: a frame
    goes out as one report (report ID 0 first); a report read in keeps the frame at its start."""

    def __init__(self, device, timeout_s: float):
        self.device = device
        self.timeout = timeout_s
        self.name = f"lobot://hid ({HID_VID:04x}:{HID_PID:04x})"
        self._buffer = bytearray()

    @classmethod
    def open_first(cls, timeout_s: float) -> HidReportPort:
        try:
            import hid  # the `hidapi` package: pip install 'choreo[lobot]'
        except ImportError:
            raise PortError(
                "lobot://hid needs the hidapi package: pip install 'choreo[lobot]' "
                "(or use the controller's UART as lobot:///dev/ttyUSB0)"
            ) from None
        if not hasattr(hid, "device"):  # the `hid` package also installs a module named hid
            raise PortError(
                "lobot://hid needs the hidapi package (module hid with hid.device), not the "
                "package named hid: pip install 'choreo[lobot]'"
            )
        device = hid.device()
        try:
            device.open(HID_VID, HID_PID)
        except OSError as error:
            raise PortError(
                f"lobot://hid: no LOBOT controller ({HID_VID:04x}:{HID_PID:04x}) could be opened "
                f"({error}); is it plugged in, and may you use /dev/hidraw* (a udev rule)?"
            ) from error
        return cls(device, timeout_s)

    def write(self, data: bytes) -> int:
        self.device.write(b"\x00" + bytes(data))
        return len(data)

    def read(self, size: int = 1) -> bytes:
        if len(self._buffer) < size:
            # hidapi blocks without end for a timeout of 0 ms: wait at least 1 ms
            report = bytes(self.device.read(HID_REPORT, max(1, round((self.timeout or 0) * 1000))))
            if report[:2] == HEADER and len(report) >= 3:
                self._buffer += report[: 2 + report[2]]  # the frame, not the report's padding
        data = bytes(self._buffer[:size])
        del self._buffer[:size]
        return data

    @property
    def in_waiting(self) -> int:
        """What is left of the last report read (the device is not asked)."""
        return len(self._buffer)

    def reset_input_buffer(self) -> None:
        self._buffer.clear()
        while self.device.read(HID_REPORT, 1):  # what is waiting (0 ms would block)
            pass

    def reset_output_buffer(self) -> None:
        """Reports are sent as they are written: nothing waits."""

    def flush(self) -> None:
        """Reports are sent as they are written: nothing waits."""

    def close(self) -> None:
        self.device.close()


LINK = Link(CAPABILITIES, board_on, move_frame)
