"""A performer in this process on loopback, and a hand-driven conductor (or impostor) session
talking to it: the protocol's messages sent one by one, as an attacker would."""

from __future__ import annotations

import json
import socket
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

from paths import DATA

from choreo.motion.motion_file import load_motion
from choreo.play.robot_bus import open_robot_bus
from choreo.show.messages import Announcement, Answer, Beat, Go, Readiness, Stop, decode, encode
from choreo.show.network import Network
from choreo.show.performer import Performer
from choreo.show.staging import pack
from choreo.show.ticket import new_ticket, signature

SHOWS = DATA / "shows"
NOD = SHOWS / "nod.yaml"  # arm6, 1 s
ARM = "sim://?ids=1-6"
WAIT_S = 30.0  # the most a step may take before the test fails (never reached when working)
# A heartbeat comes every 100 ms, but on a machine loaded by other work they were seen > 400 ms
# apart, and the part was dropped between stage and go. Only tests of that bound pass 0.4 s.
PATIENT_SILENCE_S = 2.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def eventually(condition: Callable[[], object], what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"never: {what}")
        time.sleep(0.01)


class Stage:
    """A performer (``tony`` unless named) serving in a thread, listening on a loopback port,
    on the emulated bus ``port``; what it says goes to ``say``, else to ``said``."""

    def __init__(
        self,
        max_silence_s: float = PATIENT_SILENCE_S,
        protocol: str = "tcp",
        *,
        name: str = "tony",
        port: str = ARM,
        say: Callable[[str], None] | None = None,
        **network,
    ):
        self.port = free_port()
        self.endpoint = f"{protocol}/127.0.0.1:{self.port}"
        self.said: list[str] = []
        self.network = Network(listen=[self.endpoint], **network)
        self.performer = Performer(
            self.network,
            name,
            lambda robot: open_robot_bus(robot, port),
            port,
            say or self.said.append,
            max_silence_s,
        )
        self.thread = threading.Thread(target=self.performer.serve_forever, daemon=True)
        self.thread.start()

    def heard(self, text: str) -> bool:
        return any(text in line for line in self.said)

    def close(self) -> None:
        self.performer.close()
        self.thread.join(timeout=WAIT_S)
        self.network.close()


class Caller:
    """A session that speaks the show protocol by hand: a conductor when it holds the show's
    token, beats and uses its ticket; an impostor when it leaves any of that out."""

    def __init__(self, network: Network, show_id: str = "show-1", ticket: str | None = None):
        self.network, self.show_id = network, show_id
        self.ticket = ticket if ticket is not None else new_ticket()
        self.performer = network.realm.performer("tony")
        self.key = network.realm.show(show_id)
        self._beating = threading.Event()
        self._beat_thread: threading.Thread | None = None

    def hold(self) -> None:
        """The conductor's liveliness token, and its heartbeat."""
        self.network.announce(self.key)
        self._beat_thread = threading.Thread(target=self._beat, daemon=True)
        self._beat_thread.start()

    def _beat(self) -> None:
        seq = 0
        while not self._beating.wait(0.1):
            signed = signature(self.ticket, self.show_id, "beat", seq)
            self.network.publish(f"{self.key}/beat", encode(Beat(self.show_id, seq, signed)))
            seq += 1

    def fall_silent(self) -> None:
        self._beating.set()
        if self._beat_thread is not None:
            self._beat_thread.join()

    def info(self, timeout_s: float = WAIT_S) -> Announcement | None:
        answer = self.network.ask(f"{self.performer}/info", timeout_s=timeout_s)
        return None if answer is None else decode(Announcement, answer)

    def stage(self, timeout_s: float = WAIT_S) -> Readiness | None:
        part = encode(pack(self.show_id, self.ticket, load_motion(NOD)))
        answer = self.network.ask(f"{self.performer}/stage", part, timeout_s=timeout_s)
        return None if answer is None else decode(Readiness, answer)

    def go(
        self, show_id: str | None = None, ticket: str | None = None, timeout_s: float = WAIT_S
    ) -> Answer | None:
        go = Go(show_id or self.show_id, time.time() + 1.0, ticket or self.ticket)
        answer = self.network.ask(f"{self.performer}/go", encode(go), timeout_s=timeout_s)
        return None if answer is None else decode(Answer, answer)

    def stop(self, reason: str = "test", signed_with: str | None = None) -> None:
        signed = signature(signed_with or self.ticket, self.show_id, "stop", reason)
        self.network.publish(f"{self.key}/stop", encode(Stop(self.show_id, reason, signed)))


def stage_stop_and_play(conductor: Caller, stage: Stage) -> None:
    """What a conductor the network lets through can do: stage a part, stop it with a signed
    stop, stage it again and play it to its end."""
    conductor.hold()
    try:
        assert conductor.stage().ok
        conductor.stop("from the conductor")
        eventually(lambda: stage.heard("part dropped"), "the part is dropped")
        assert stage.heard("stopped by the conductor: from the conductor: part dropped")
        eventually(lambda: conductor.info().state == "idle", "the performer is free again")
        assert conductor.stage().ok
        assert conductor.go().ok
        eventually(lambda: stage.heard("part completed"), "the part plays to its end")
    finally:
        conductor.fall_silent()


# --- mutual TLS: certificates made with openssl, and Zenoh configurations using them ---------
# P-256 keys: made in milliseconds, where an RSA 2048 key takes 0.2 s of CPU (nine per run)
NEW_KEY = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1")


def openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


def make_certificates(folder: Path, addresses: tuple[str, ...] = ()) -> None:
    """A CA, and a certificate it signed for the performer and for the conductor, each valid
    for localhost, 127.0.0.1 and ``addresses``."""
    openssl("req", "-x509", *NEW_KEY, "-nodes", "-days", "1", "-subj", "/CN=show CA",
            "-keyout", "ca.key", "-out", "ca.pem", cwd=folder)  # fmt: skip
    for who in ("performer", "conductor"):
        sign_certificate(folder, who, addresses)


def sign_certificate(folder: Path, who: str, addresses: tuple[str, ...] = ()) -> None:
    """A certificate for ``who`` (its common name) signed by the CA in ``folder``."""
    openssl("req", *NEW_KEY, "-nodes", "-subj", f"/CN={who}",
            "-keyout", f"{who}.key", "-out", f"{who}.csr", cwd=folder)  # fmt: skip
    names = ",".join(["DNS:localhost", "IP:127.0.0.1", *(f"IP:{a}" for a in addresses)])
    (folder / f"{who}.ext").write_text(f"subjectAltName={names}\n")
    openssl("x509", "-req", "-in", f"{who}.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
            "-CAcreateserial", "-days", "1", "-extfile", f"{who}.ext",
            "-out", f"{who}.pem", cwd=folder)  # fmt: skip


def tls_config(
    folder: Path, who: str | None, *, mutual: bool = True, trusting: Path | None = None
) -> Path:
    """A Zenoh configuration trusting the CA in ``trusting`` (default ``folder``), presenting
    ``who``'s certificate from ``folder`` (None: none), asking for the other side's with
    ``mutual``."""
    tls: dict[str, object] = {"root_ca_certificate": str((trusting or folder) / "ca.pem")}
    if mutual:
        tls["enable_mtls"] = True
    if who is not None:
        for side in ("listen", "connect"):
            tls[f"{side}_private_key"] = str(folder / f"{who}.key")
            tls[f"{side}_certificate"] = str(folder / f"{who}.pem")
    path = folder / f"{who or 'stranger'}-{mutual}.json5"
    path.write_text(json.dumps({"transport": {"link": {"tls": tls}}}))
    return path
