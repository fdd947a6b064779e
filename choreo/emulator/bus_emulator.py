"""The emulated bus: host bytes in, servo replies out, on a wire with real timing.

Timing model (``docs/protocol.md``):

- Every byte takes ``BYTE_TIME_S`` (10 bits at 115200 baud). The host's writes queue on the wire
  one after another, starting no earlier than the moment they are written.
- A servo acts when the last byte of a packet has arrived. Its reply's first byte starts
  ``turnaround_s`` later; the host has each reply byte once that byte has crossed the wire.
- With ``echo`` (DIY one-wire wiring) the host also receives each of its own bytes as it crosses.
- Several servos answering the same packet (duplicate IDs, broadcast ID_READ) talk over each other:
  the open-drain line gives the bitwise AND of their bytes, and since real servos drift by a few
  bit-times against each other, the result never passes the checksum (we force that, so a
  collision is always detectable as one rather than silently looking like one servo's reply).
- Not modelled: the host transmitting while a servo replies (a collision on a real bus).

The bus is lazy and event-driven: nothing runs in the background. Whatever observes it (the port's
``read``, ``in_waiting``, a servo's properties) first delivers every byte due by ``clock.now()``,
in time order. With a ``VirtualClock`` the port advances the clock to exactly when the bytes it
waits for arrive, so tests are deterministic and instant; with a ``RealClock`` it runs in real time.

EEPROM values persist to a JSON state file (``state_path``), written atomically after every
EEPROM write, like the servo's own EEPROM.
"""

from __future__ import annotations

import heapq
import json
import logging
import math
import os
import random
import threading
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Protocol

from choreo.bus.protocol import BYTE_TIME_S, Packet, PacketDecoder, checksum, parse_ids
from choreo.bus.servo_models import ServoModel, servo_model
from choreo.core.arguments import Range, check_number
from choreo.core.atomic import write_text_atomically
from choreo.core.clock import Clock, RealClock
from choreo.core.file_kind import not_a_file, os_error_text
from choreo.emulator.eeprom import Eeprom
from choreo.emulator.emulated_servo import DEFAULT_START_GAP_S, EmulatedServo, StartedMove
from choreo.emulator.physics import Physics
from choreo.emulator.reply_faults import ReplyFate
from choreo.errors import ChoreoError


class DirectionGate(Protocol):
    """GPIO direction lines in front of the host (``direction_gate.FakeDirectionLines``)."""

    def open_throughout(self, start_s: float, end_s: float, line: str) -> bool:
        """Whether ``line`` ("tx" or "rx") was on from ``start_s`` until ``end_s``."""
        ...


logger = logging.getLogger(__name__)

DEFAULT_TURNAROUND_S = 0.0006  # one measurement of a real servo (protocol.md)
MAX_TURNAROUND_MS = 1000.0  # a real servo answers in under a millisecond
TURNAROUND_S = Range(at_least=0, at_most=MAX_TURNAROUND_MS / 1000, unit=" s")
START_GAP_S = Range(at_least=0, unit=" s")  # a finite gap: inf would refuse every START
DEFAULT_LOG_LIMIT = 100_000  # entries per log list; a long-running emulator must not grow forever
STATE_FORMAT = "choreo-emulator-state"
STATE_VERSION = 1


@dataclass(frozen=True)
class ServoSpec:
    """One servo to put on the bus: its factory ID, model (None: the bus default), position."""

    servo_id: int
    model: str | None = None
    position_units: float = 500.0


def parse_servo_specs(text: str) -> list[ServoSpec]:
    """``"1-6,9,12-14"``; a group may name its model: ``"1-6,7-8:LX-224HV"``."""
    specs: list[ServoSpec] = []
    for group in text.split(","):  # one group at a time: "1,1" puts two servos with ID 1 on the bus
        ids_text, _, model = group.strip().partition(":")
        if model:
            servo_model(model)  # ValueError listing the known models
        try:
            ids = parse_ids(ids_text)
        except ValueError as error:
            raise ValueError(
                f"bad servo IDs {group.strip()!r} ({error}): each comma-separated group is an ID "
                "or a range like 1-6, optionally followed by :MODEL, as in 1-6,9,12-14:LX-224HV"
            ) from None
        specs.extend(ServoSpec(servo_id, model or None) for servo_id in ids)
    return specs


@dataclass(frozen=True)
class ReceivedPacket:
    """A valid packet from the host; ``time_s`` is when its last byte arrived."""

    time_s: float
    packet: Packet


@dataclass(frozen=True)
class SentReply:
    """A reply on the wire; ``time_s`` is when its last byte reaches the host."""

    time_s: float
    servo_ids: tuple[int, ...]
    data: bytes
    fate: ReplyFate


class WireLog:
    """What happened on the wire, newest last; each list keeps at most ``limit`` entries."""

    def __init__(self, limit: int = DEFAULT_LOG_LIMIT):
        self.packets: deque[ReceivedPacket] = deque(maxlen=limit)
        self.replies: deque[SentReply] = deque(maxlen=limit)
        self.moves: deque[StartedMove] = deque(maxlen=limit)


class BusEmulator:
    """Servos on one half-duplex bus. Thread-safe: every public method holds one lock.

    ``direction``: optional GPIO enable lines in front of the host (a test's
    :class:`~choreo.emulator.direction_gate.FakeDirectionLines`): a host byte is lost unless
    transmit was on while it crossed, a byte for the host is lost unless receive was on.
    ``drain_late_s``: how long after the wire is free the port's ``flush()`` (tcdrain) returns;
    Linux's serial core sleeps at least a jiffy there (4-20 ms), the emulator 0 unless told.
    ``physics``: a physical world behind the servos (``physics.py``); its servos replace
    ``servos``, standing and holding where it puts them.
    """

    board_kind: str | None = None  # a controller board in front of the servos (boards.py)
    host_byte_time_s = BYTE_TIME_S  # the host's link: the servo bus itself here

    def __init__(
        self,
        servos: Iterable[int | ServoSpec] = range(1, 7),
        *,
        model: str = "LX-16A",
        clock: Clock | None = None,
        turnaround_s: float = DEFAULT_TURNAROUND_S,
        echo: bool = False,
        start_gap_s: float = DEFAULT_START_GAP_S,
        seed: int = 0,
        state_path: str | os.PathLike | None = None,
        log_limit: int = DEFAULT_LOG_LIMIT,
        physics: Physics | None = None,
    ):
        check_number("turnaround_s", turnaround_s, TURNAROUND_S)
        check_number("start_gap_s", start_gap_s, START_GAP_S)
        specs = [ServoSpec(s) if isinstance(s, int) else s for s in servos]
        if physics is not None:  # the world's servos, standing as it puts them
            specs = [ServoSpec(s.servo_id, s.model, s.position_units) for s in physics.servos]
        worlds = [s.physics for s in physics.servos] if physics else [None] * len(specs)
        speeds = [s.top_speed_deg_s for s in physics.servos] if physics else [None] * len(specs)
        self.physics = physics
        self.clock = clock if clock is not None else RealClock()
        self.turnaround_s = turnaround_s
        self._echo = echo
        self._log = WireLog(log_limit)
        self.state_path = Path(state_path) if state_path is not None else None
        self._lock = threading.RLock()
        self._rng = random.Random(seed)
        self._decoder = PacketDecoder()
        self._tx: deque[tuple[float, int]] = (
            deque()
        )  # host bytes: (time the last bit is sent, byte)
        self._in_flight: list[tuple[float, int, int]] = []  # heap of (arrival time, seq, byte)
        self._seq = 0
        self._arrived = bytearray()  # bytes the host can read
        self._wire_free_s = -math.inf
        self.direction: DirectionGate | None = None
        self.drain_late_s = 0.0
        self._layout = [(spec.servo_id, spec.model or model) for spec in specs]
        self._eeproms = self._load_state() or [Eeprom(servo_id) for servo_id, _ in self._layout]
        self.servos: tuple[EmulatedServo, ...] = tuple(
            EmulatedServo(
                _capped_at(servo_model(model_name), speed),
                eeprom,
                self._now,
                lock=self._lock,
                position_units=spec.position_units,
                start_gap_s=start_gap_s,
                physics=world,
                loaded=world is not None,  # the robot stands in its world: its servos hold
            )
            for spec, (_, model_name), eeprom, world, speed in zip(
                specs, self._layout, self._eeproms, worlds, speeds
            )
        )

    @property
    def echo(self) -> bool:
        """True: the host receives its own bytes as they cross the wire (one-wire DIY wiring)."""
        return self._echo

    @echo.setter
    def echo(self, echo: bool) -> None:
        with self._lock:
            self.catch_up()
            self._echo = echo

    @property
    def log(self) -> WireLog:
        """What happened on the wire up to now."""
        with self._lock:
            self.catch_up()
            return self._log

    # --- servos ----------------------------------------------------------------------------
    def servo(self, servo_id: int) -> EmulatedServo:
        """The one servo that now answers to ``servo_id``."""
        with self._lock:
            self.catch_up()
            found = [s for s in self.servos if s.servo_id == servo_id]
            if len(found) != 1:
                ids = ", ".join(str(s.servo_id) for s in self.servos)
                raise ValueError(f"{len(found)} servos have ID {servo_id}; IDs on the bus: {ids}")
            return found[0]

    # --- the host side of the wire ---------------------------------------------------------
    def write(self, data: bytes) -> None:
        """Queue host bytes on the wire from now (after whatever the host sent before)."""
        with self._lock:
            now = self.clock.now()
            self.catch_up()
            start = max(now, self._wire_free_s)
            for index, byte in enumerate(data):
                self._tx.append((start + (index + 1) * self.host_byte_time_s, byte))
            if data:
                self._wire_free_s = start + len(data) * self.host_byte_time_s

    @property
    def wire_free_s(self) -> float:
        """When the last byte the host has written will have left (may be in the past)."""
        with self._lock:
            return self._wire_free_s

    @property
    def out_waiting(self) -> int:
        """Host bytes not yet fully sent."""
        with self._lock:
            self.catch_up()
            return len(self._tx)

    def cancel_unsent(self) -> None:
        """Drop host bytes that have not started on the wire (``reset_output_buffer``)."""
        with self._lock:
            self.catch_up()
            now = self.clock.now()
            while self._tx and self._tx[-1][0] - self.host_byte_time_s >= now:
                self._tx.pop()
            self._wire_free_s = self._tx[-1][0] if self._tx else now

    @property
    def in_waiting(self) -> int:
        """Bytes the host can read now."""
        with self._lock:
            self.catch_up()
            return len(self._arrived)

    def take_received(self, max_bytes: int | None = None) -> bytes:
        """Up to ``max_bytes`` (all if None) of the bytes the host can read now."""
        with self._lock:
            self.catch_up()
            count = len(self._arrived) if max_bytes is None else max_bytes
            data = bytes(self._arrived[:count])
            del self._arrived[:count]
            return data

    def discard_received(self) -> None:
        """Drop what the host could read now; bytes still on their way arrive later."""
        with self._lock:
            self.catch_up()
            self._arrived.clear()

    def next_event_s(self) -> float:
        """When the next host byte finishes or the next byte reaches the host (inf: nothing due);
        now if bytes have reached it and wait to be taken: another thread (a test reading the
        ``log``) may have caught up since the reader's last ``take_received``. Without that, a
        pty's bridge waited for the host's next write, and the host timed out on a reply that
        had arrived (seconds at a time, on a busy machine)."""
        with self._lock:
            if self._arrived:
                return self.clock.now()
            rx_s = self._in_flight[0][0] if self._in_flight else math.inf
            return min(self._next_cause_s(), rx_s)

    def _next_cause_s(self) -> float:
        """When the next event that may send bytes to the host happens: a host byte finishing
        (a servo may answer the packet it ends, or echo it)."""
        return self._tx[0][0] if self._tx else math.inf

    def run_until_received(self, count: int, deadline_s: float) -> float:
        """For virtual clocks: run events in time order (without moving the clock) until
        ``count`` bytes can be read or ``deadline_s``; returns that time (inf: never).

        It stops at every event that may send the host bytes and at the byte in flight that
        makes ``count``, not at each before it (which cannot make it): a request to a servo
        and its reply in 7 stops, not 14. Too few in flight, it stops at each, so that they
        have all arrived when it gives up."""
        with self._lock:
            time_s = self.clock.now()
            self._advance_to(time_s)
            while len(self._arrived) < count:
                needed, in_flight = count - len(self._arrived), self._in_flight
                if len(in_flight) >= needed:
                    arrival_s = heapq.nsmallest(needed, in_flight)[-1][0]
                else:
                    arrival_s = in_flight[0][0] if in_flight else math.inf
                next_s = min(self._next_cause_s(), arrival_s)
                if next_s > deadline_s or math.isinf(next_s):  # nothing more before the deadline
                    return deadline_s
                self._advance_to(next_s)
                time_s = next_s
            return time_s

    def catch_up(self) -> None:
        """Deliver everything due by ``clock.now()``."""
        with self._lock:
            self._advance_to(self.clock.now())

    def _now(self) -> float:
        with self._lock:
            self.catch_up()
            return self.clock.now()

    def _advance_to(self, time_s: float) -> None:
        while True:
            tx_s = self._tx[0][0] if self._tx else math.inf
            rx_s = self._in_flight[0][0] if self._in_flight else math.inf
            if min(tx_s, rx_s) > time_s:
                return
            if rx_s <= tx_s:
                arrival_s, _, byte = heapq.heappop(self._in_flight)
                if self._passes(arrival_s, "rx"):
                    self._arrived.append(byte)
            else:
                self._deliver_host_byte(*self._tx.popleft())

    def _passes(self, end_s: float, line: str) -> bool:
        """Whether the direction lines let a byte crossing until ``end_s`` through."""
        if self.direction is None:
            return True
        return self.direction.open_throughout(end_s - self.host_byte_time_s, end_s, line)

    def _deliver_host_byte(self, time_s: float, byte: int) -> None:
        if not self._passes(time_s, "tx"):
            return  # transmit was off: the byte never reached the bus
        if self._echo:
            self._schedule(time_s, bytes((byte,)))
        for packet in self._decoder.feed(bytes((byte,))):
            self._handle(packet, time_s)

    def _schedule(self, last_byte_s: float, data: bytes) -> None:
        byte_s = self.host_byte_time_s
        first_byte_s = last_byte_s - (len(data) - 1) * byte_s
        for index, byte in enumerate(data):
            self._seq += 1
            heapq.heappush(self._in_flight, (first_byte_s + index * byte_s, self._seq, byte))

    # --- servos acting on a packet ---------------------------------------------------------
    def _handle(self, packet: Packet, at_s: float) -> None:
        self._log.packets.append(ReceivedPacket(at_s, packet))
        replies = []
        eeprom_changed = False
        for slot, servo in enumerate(self.servos):
            if not servo.hears(packet):
                continue
            outcome = servo.handle(packet, at_s)
            self._log.moves.extend(outcome.moves)
            eeprom_changed |= outcome.eeprom != self._eeproms[slot]
            self._eeproms[slot] = outcome.eeprom
            if outcome.reply is not None:
                replies.append((servo, outcome.reply))
        if eeprom_changed and self.state_path is not None:
            self._save_state(self.state_path)
        if replies:
            self._send_replies(replies, at_s)

    def _send_replies(
        self, replies: list[tuple[EmulatedServo, bytes]], request_end_s: float
    ) -> None:
        sent = []
        for servo, data in replies:
            fate, data = self._apply_reply_faults(servo, data)
            last_byte_s = request_end_s + self.turnaround_s + len(data) * BYTE_TIME_S
            servo_id = data[2]  # the reply's header carries the servo's real ID
            if fate is ReplyFate.DROPPED:
                self._log.replies.append(SentReply(last_byte_s, (servo_id,), data, fate))
            else:
                sent.append((servo_id, data, fate))
        if not sent:
            return
        if len(sent) > 1:
            servo_ids = tuple(servo_id for servo_id, _, _ in sent)
            data, fate = _collide([data for _, data, _ in sent]), ReplyFate.COLLIDED
        else:
            ((servo_id, data, fate),) = sent
            servo_ids = (servo_id,)
        last_byte_s = request_end_s + self.turnaround_s + len(data) * BYTE_TIME_S
        self._schedule(last_byte_s, data)
        self._log.replies.append(SentReply(last_byte_s, servo_ids, data, fate))

    def _apply_reply_faults(self, servo: EmulatedServo, data: bytes) -> tuple[ReplyFate, bytes]:
        fate = servo.take_reply_fault(self._rng.random)
        return fate, self._flip_a_bit(data) if fate is ReplyFate.CORRUPTED else data

    def _flip_a_bit(self, data: bytes) -> bytes:
        # A flipped bit after CMD (parameters or checksum) always breaks the checksum, and the
        # frame still parses, so the host sees exactly "a reply with a bad checksum".
        garbled = bytearray(data)
        garbled[self._rng.randrange(5, len(data))] ^= 1 << self._rng.randrange(8)
        return bytes(garbled)

    # --- EEPROM persistence ----------------------------------------------------------------
    def save_state(self) -> None:
        """Write every servo's EEPROM to ``state_path`` (atomically)."""
        with self._lock:
            self.catch_up()
            if self.state_path is None:
                raise ValueError("this emulator has no state_path to save to")
            self._save_state(self.state_path)

    def _save_state(self, path: Path) -> None:
        document = {
            "format": STATE_FORMAT,
            "version": STATE_VERSION,
            "servos": [
                {"factory_id": factory_id, "model": model_name, "eeprom": asdict(eeprom)}
                for (factory_id, model_name), eeprom in zip(self._layout, self._eeproms)
            ],
        }
        write_text_atomically(path, json.dumps(document, indent=2) + "\n")

    def _load_state(self) -> list[Eeprom] | None:
        if self.state_path is None:
            return None
        path = self.state_path
        kind = not_a_file(path)
        if kind is not None:
            raise ChoreoError(f"{path}: cannot read emulator state: it is {kind}, not a file")
        if not path.exists():
            if not path.parent.is_dir():  # never made behind the user's back
                raise ChoreoError(
                    f"emulator state {path}: the folder {path.parent} does not exist; create "
                    "it, or name a state file in an existing folder"
                )
            return None
        try:
            document = json.loads(path.read_text())
            if not isinstance(document, dict):
                raise ValueError(f"not a {STATE_FORMAT} file: a JSON object is expected")
            if document.get("format") != STATE_FORMAT or document.get("version") != STATE_VERSION:
                raise ValueError(f"not a {STATE_FORMAT} file of version {STATE_VERSION}")
            saved_layout = [(s["factory_id"], s["model"]) for s in document["servos"]]
            if saved_layout != self._layout:
                raise ChoreoError(
                    f"{path}: saved for servos {_describe(saved_layout)}, but this emulator has "
                    f"{_describe(self._layout)}; start it with the same servos or delete the file"
                )
            return [Eeprom(**s["eeprom"]) for s in document["servos"]]
        except OSError as error:
            raise ChoreoError(f"cannot read emulator state: {os_error_text(error)}") from error
        except json.JSONDecodeError as error:  # its words are json's: where is what matters
            raise ChoreoError(
                f"{path}:{error.lineno}:{error.colno}: cannot read emulator state: not JSON; "
                f"{_START_AFRESH}"
            ) from error
        except (KeyError, TypeError) as error:  # a servo's entry lacks a field, or has another
            raise ChoreoError(
                f"{path}: cannot read emulator state: not a {STATE_FORMAT} file of version "
                f"{STATE_VERSION} (a servo's entry is damaged); {_START_AFRESH}"
            ) from error
        except ValueError as error:
            raise ChoreoError(
                f"{path}: cannot read emulator state: {error}; {_START_AFRESH}"
            ) from error


_START_AFRESH = "delete it to start from the servos' factory settings"


def _collide(replies: Sequence[bytes]) -> bytes:
    length = max(len(r) for r in replies)
    merged = bytearray(b"\xff" * length)  # an idle line reads as all ones
    for reply in replies:
        for index, byte in enumerate(reply):
            merged[index] &= byte
    merged[-1] = checksum(merged[2:-1]) ^ 0xFF
    return bytes(merged)


def _describe(layout: Sequence[tuple[int, str]]) -> str:
    return ", ".join(f"{servo_id} ({model_name})" for servo_id, model_name in layout)


def _capped_at(model: ServoModel, top_speed_deg_s: float | None) -> ServoModel:
    """``model`` whose own moves are capped at ``top_speed_deg_s`` (None: its datasheet's)."""
    if top_speed_deg_s is None:
        return model
    return replace(model, no_load_speed_deg_s=top_speed_deg_s)
