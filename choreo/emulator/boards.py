"""Emulated controller boards in front of the emulated servos: the RRC board and the LOBOT
Bus Servo Controller (``sim://?board=rrc``, ``choreo emulate --board lobot``).

The host talks to the board over its own link (RRC: 1,000,000 baud; LOBOT: its 9600-baud UART).
When a whole frame has arrived the board acts on it, one frame after another: it sends one LX
packet per servo on the 115200-baud servo bus and waits for each to leave before the next (about
0.87 ms per 10-byte packet), so the servos of one move frame start one after another. For a read
it waits for the servo's reply at most 5 ms (RRC: then answers status FF). The servos are those of
:class:`BusEmulator`; its wire log records the LX packets with the times they reached the
servos, so tests measure the boards' start skew from it. The RRC board also sends a battery frame
once a second, unasked.

Assumed where no source says (docs/transports.md): the LOBOT board forwards like the RRC and
leaves a servo that did not answer out of a position-read reply; both boards take 50 µs to
start acting on a frame.
"""

from __future__ import annotations

import math
import struct
from typing import ClassVar

from choreo.bus.protocol import BYTE_TIME_S, Command, PacketDecoder, encode_packet
from choreo.bus.transports import Link, lobot, rrc
from choreo.emulator.bus_emulator import BusEmulator, SentReply
from choreo.emulator.reply_faults import ReplyFate

BOARD_LATENCY_S = 0.00005
SERVO_REPLY_TIMEOUT_S = 0.005  # RRC firmware: proc_timeout, 5 ticks of 1 ms
RRC_BATTERY_PERIOD_S = 1.0
BATTERY_MV = 7400


class BoardEmulator(BusEmulator):
    """Common part: frames in from the host, LX packets out to the servos one at a time."""

    host_link: ClassVar[Link]  # what the host speaks to this board: the real board's frames
    _frames: rrc.FrameDecoder | lobot.FrameDecoder  # the board's own framing

    def __init__(self, *args, **kwargs):
        kwargs["echo"] = False  # the board's link does not echo
        super().__init__(*args, **kwargs)
        self.battery_mv = BATTERY_MV
        self._busy_until_s = -math.inf
        self._to_host_free_s = -math.inf
        self._heard: list | None = None

    def _deliver_host_byte(self, time_s: float, byte: int) -> None:
        for frame in self._frames.feed(bytes((byte,))):
            start_s = max(time_s + BOARD_LATENCY_S, self._busy_until_s)
            self._busy_until_s = self._act(frame, start_s)

    def _act(self, frame, start_s: float) -> float:
        """Carry out one host frame from ``start_s``; returns when the board is free again."""
        raise NotImplementedError

    def _send_replies(self, replies, request_end_s: float) -> None:
        self._heard = replies  # the board hears the servos, not the host

    def _lx(self, at_s: float, command: Command, servo_id: int, params: bytes = b""):
        """Send one LX packet from ``at_s``; returns (when it has left, reply parameters or None,
        when the board stops waiting for the reply)."""
        data = encode_packet(servo_id, command, params)
        end_s = at_s + len(data) * BYTE_TIME_S
        self._heard = None
        self._handle(PacketDecoder().feed(data)[0], end_s)
        heard: list = self._heard or []
        self._heard = None
        if not heard:
            return end_s, None, end_s + SERVO_REPLY_TIMEOUT_S
        sent = []
        for servo, reply in heard:
            fate, reply = self._apply_reply_faults(servo, reply)
            last_s = end_s + self.turnaround_s + len(reply) * BYTE_TIME_S
            self._log.replies.append(SentReply(last_s, (reply[2],), reply, fate))
            if fate is not ReplyFate.DROPPED:
                sent.append((fate, reply, last_s))
        if len(sent) != 1 or sent[0][0] is ReplyFate.CORRUPTED:  # silence, collision or garble
            return end_s, None, end_s + SERVO_REPLY_TIMEOUT_S
        _, reply, last_s = sent[0]
        if last_s > end_s + SERVO_REPLY_TIMEOUT_S:
            return end_s, None, end_s + SERVO_REPLY_TIMEOUT_S
        return end_s, reply[5:-1], last_s

    def _to_host(self, at_s: float, frame: bytes) -> None:
        """Send a frame to the host once the frames before it have gone (one UART)."""
        start_s = max(at_s, self._to_host_free_s)
        self._to_host_free_s = start_s + len(frame) * self.host_byte_time_s
        self._schedule(self._to_host_free_s, frame)


class RrcBoardEmulator(BoardEmulator):
    """The RRC board's bus-servo sub-commands (FUNC 5), as its firmware handles them."""

    board_kind = "rrc"
    host_link = rrc.LINK
    host_byte_time_s = rrc.CAPABILITIES.host_byte_time_s
    _next_battery_s = math.inf  # set once the servos exist

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._frames = rrc.FrameDecoder()
        self._next_battery_s = self.clock.now() + RRC_BATTERY_PERIOD_S

    # The battery frame, once a second, is an event of its own (it sends the host a frame).
    def _next_cause_s(self) -> float:
        return min(super()._next_cause_s(), self._next_battery_s)

    def _advance_to(self, time_s: float) -> None:
        while self._next_battery_s <= time_s:
            due_s = self._next_battery_s
            self._next_battery_s += RRC_BATTERY_PERIOD_S
            super()._advance_to(due_s)
            data = bytes((rrc.SYS_BATTERY,)) + self.battery_mv.to_bytes(2, "little")
            self._to_host(due_s, rrc.encode_frame(rrc.FUNC_SYS, data))
        super()._advance_to(time_s)

    def _act(self, frame: rrc.Frame, start_s: float) -> float:
        data = frame.data
        if frame.func != rrc.FUNC_BUS_SERVO or not data:
            return start_s  # LEDs, buzzer, motors...: nothing on the servo bus
        sub, at_s = data[0], start_s
        if sub == rrc.MOVE and len(data) >= 4:
            time_ms, count = struct.unpack_from("<HB", data, 1)
            for i in range(count):
                servo_id, pos = struct.unpack_from("<BH", data, 4 + 3 * i)
                params = struct.pack("<HH", min(pos, 1000), time_ms)
                at_s, _, _ = self._lx(at_s, Command.MOVE_TIME_WRITE, servo_id, params)
            return at_s
        if sub == rrc.STOP and len(data) >= 2:
            for servo_id in data[2 : 2 + data[1]]:
                at_s, _, _ = self._lx(at_s, Command.MOVE_STOP, servo_id)
            return at_s
        if len(data) < 2:
            return start_s
        servo_id, rest = data[1], data[2:]
        if sub in (rrc.UNLOAD, rrc.LOAD):
            loaded = bytes((1 if sub == rrc.LOAD else 0,))
            return self._lx(at_s, Command.LOAD_OR_UNLOAD_WRITE, servo_id, loaded)[0]
        writes = {v: k for k, v in rrc.WRITE_SUBS.items()}
        if sub in writes:
            return self._lx(at_s, writes[sub], servo_id, _clamped(sub, rest))[0]
        reads = {v: k for k, v in rrc.READ_SUBS.items()}
        if sub not in reads:
            return start_s  # the firmware ignores unknown sub-commands
        _, value, done_s = self._lx(at_s, reads[sub], servo_id)
        size = rrc.reply_total(reads[sub]) - 8
        status = 0 if value is not None else 0xFF
        reply = bytes((servo_id, sub, status)) + (value if value is not None else bytes(size))
        self._to_host(done_s + BOARD_LATENCY_S, rrc.encode_frame(rrc.FUNC_BUS_SERVO, reply))
        return done_s


def _clamped(sub: int, params: bytes) -> bytes:
    """The board's own clamps on EEPROM writes (firmware ``serial_servo.c``)."""
    if sub == 0x30 and len(params) == 4:
        low, high = (min(v, 1000) for v in struct.unpack("<HH", params))
        return struct.pack("<HH", min(low, high), max(low, high))
    if sub == 0x34 and len(params) == 4:
        low, high = struct.unpack("<HH", params)
        return struct.pack("<HH", max(low, 4500), min(high, 14000))
    if sub == 0x38 and len(params) == 1:
        return bytes((min(params[0], 100),))
    return params


class LobotBoardEmulator(BoardEmulator):
    """The LOBOT Bus Servo Controller on its 9600-baud UART: commands 03, 0F, 14, 15."""

    board_kind = "lobot"
    host_link = lobot.LINK
    host_byte_time_s = lobot.CAPABILITIES.host_byte_time_s

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._frames = lobot.FrameDecoder()

    def _act(self, frame: lobot.Frame, start_s: float) -> float:
        params, at_s = frame.params, start_s
        if frame.command == lobot.MOVE and len(params) >= 3:
            count, time_ms = struct.unpack_from("<BH", params)
            for i in range(count):
                servo_id, pos = struct.unpack_from("<BH", params, 3 + 3 * i)
                at_s, _, _ = self._lx(
                    at_s, Command.MOVE_TIME_WRITE, servo_id, struct.pack("<HH", pos, time_ms)
                )
            return at_s
        if frame.command == lobot.BATTERY:
            self._to_host(
                at_s, lobot.encode_frame(lobot.BATTERY, struct.pack("<H", self.battery_mv))
            )
            return at_s
        if frame.command == lobot.UNLOAD and params:
            for servo_id in params[1 : 1 + params[0]]:
                at_s, _, _ = self._lx(at_s, Command.LOAD_OR_UNLOAD_WRITE, servo_id, b"\x00")
            return at_s
        if frame.command == lobot.READ_POSITIONS and params:
            found = b""
            for servo_id in params[1 : 1 + params[0]]:
                _, value, at_s = self._lx(at_s, Command.POS_READ, servo_id)
                if value is not None:
                    found += bytes((servo_id,)) + value
            reply = bytes((len(found) // 3,)) + found
            self._to_host(at_s + BOARD_LATENCY_S, lobot.encode_frame(lobot.READ_POSITIONS, reply))
            return at_s
        return start_s


BOARDS: dict[str, type[BoardEmulator]] = {"rrc": RrcBoardEmulator, "lobot": LobotBoardEmulator}
