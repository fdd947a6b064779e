"""The Zenoh session's configuration: Zenoh's own file (or ZENOH_CONFIG), the realm, the
one-line warning when a session can be reached from beyond this computer unauthenticated, and
why an endpoint cannot be listened on or connected to, in choreo's words."""

from __future__ import annotations

import json
import socket

import pytest
import zenoh  # the test extra's: a missing one fails the file, never skips it
from show_helpers import eventually

from choreo.errors import OptionError
from choreo.show.network import CONFIG_ENV, Network, Realm, exposure


def config(**settings) -> object:
    made = zenoh.Config()
    for key, value in settings.items():
        made.insert_json5(key.replace("__", "/"), json.dumps(value))
    return made


def test_keys_live_under_the_realm():
    assert Realm("lab").performer("tony") == "choreo/lab/performers/tony"
    assert Realm("lab").show("duo-1") == "choreo/lab/shows/duo-1"
    assert Realm().performer("tony") == "choreo/default/performers/tony"


def test_two_realms_never_see_each_other(tmp_path):
    port = f"tcp/127.0.0.1:{_free_port()}"
    with (
        Network(listen=[port], realm="lab") as lab,
        Network(connect=[port], realm="stage") as stage,
        Network(connect=[port], realm="lab") as lab_too,
    ):
        lab.announce(lab.realm.performer("tony"))
        stage.announce(stage.realm.performer("tony"))
        eventually(lambda: lab_too.alive(lab_too.realm.performer("*")), "lab's token is seen")
        assert lab_too.alive(lab_too.realm.performer("*")) == ["choreo/lab/performers/tony"]
        eventually(lambda: stage.alive(stage.realm.performer("*")), "stage's own token")
        assert stage.alive(stage.realm.performer("*")) == ["choreo/stage/performers/tony"]


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_realm_that_is_not_a_name_is_refused_before_zenoh_opens():
    with pytest.raises(OptionError) as raised:
        Network(listen=["tcp/127.0.0.1:0"], realm="a/b")
    assert raised.value.option == "realm"


def test_the_configuration_file_is_zenoh_s_own(tmp_path, monkeypatch):
    file = tmp_path / "zenoh.json5"
    file.write_text('{mode: "peer", listen: {endpoints: ["tcp/127.0.0.1:0"]}, '
                    "scouting: {multicast: {enabled: false}}}")  # fmt: skip
    monkeypatch.delenv(CONFIG_ENV, raising=False)
    with Network(zenoh_config=file) as network:
        assert network.exposure is None  # loopback only
    monkeypatch.setenv(CONFIG_ENV, str(file))
    with Network() as network:  # ZENOH_CONFIG, as Zenoh's own tools read it
        assert network.exposure is None


@pytest.mark.parametrize("text", ['{mode: "bogus"}', "{not json"])
def test_a_configuration_zenoh_cannot_use_is_an_option_error(tmp_path, monkeypatch, text):
    file = tmp_path / "zenoh.json5"
    file.write_text(text)
    with pytest.raises(OptionError) as raised:
        Network(zenoh_config=file)
    assert raised.value.option == "zenoh_config"
    assert raised.value.problem.startswith(f"{file} is not a Zenoh configuration file that can")
    assert ".rs:" not in raised.value.problem and "\n" not in raised.value.problem
    monkeypatch.setenv(CONFIG_ENV, str(tmp_path / "missing.json5"))
    with pytest.raises(OptionError, match=rf"\(from {CONFIG_ENV}\)"):
        Network()


LOOPBACK = {"listen__endpoints": ["tcp/127.0.0.1:7447"], "scouting__multicast__enabled": False}


@pytest.mark.parametrize(
    "settings, warned",
    [
        ({}, True),  # Zenoh's defaults: every interface, multicast scouting
        (LOOPBACK, False),
        ({**LOOPBACK, "connect__endpoints": ["tcp/[::1]:7448"]}, False),
        ({**LOOPBACK, "scouting__multicast__enabled": True}, True),
        ({"listen__endpoints": ["tcp/0.0.0.0:7447"], "scouting__multicast__enabled": False}, True),
        # mutual TLS on every link: authenticated
        (
            {
                "listen__endpoints": ["tls/0.0.0.0:7447"],
                "transport__link__tls__enable_mtls": True,
            },
            False,
        ),
        # TLS without client certificates: anyone may connect
        ({"listen__endpoints": ["tls/0.0.0.0:7447"]}, True),
        # mTLS, but also a plain TCP listener
        (
            {
                "listen__endpoints": ["tls/0.0.0.0:7447", "tcp/0.0.0.0:7448"],
                "transport__link__tls__enable_mtls": True,
            },
            True,
        ),
        # user/password checked against a dictionary
        ({"transport__auth__usrpwd__dictionary_file": "/etc/choreo/users.txt"}, False),
        # a client whose router checks its user/password
        (
            {
                "mode": "client",
                "connect__endpoints": ["tcp/10.0.0.1:7447"],
                "transport__auth__usrpwd__user": "robot",
                "transport__auth__usrpwd__password": "secret",
            },
            False,
        ),
        ({"mode": "client", "connect__endpoints": ["tcp/10.0.0.1:7447"]}, True),
    ],
)
def test_a_session_reachable_from_outside_without_authentication_is_warned(settings, warned):
    warning = exposure(config(**settings))
    assert (warning is not None) is warned
    if warning:
        assert "\n" not in warning and "docs/shows.md" in warning


def test_a_wait_on_zenoh_still_hears_ctrl_c_and_passes_results_and_errors_through():
    import os
    import signal
    import threading

    from choreo.show.network import _interruptible

    assert _interruptible(lambda: 42) == 42
    with pytest.raises(ValueError, match="inside"):
        _interruptible(lambda: (_ for _ in ()).throw(ValueError("inside")))
    released = threading.Event()
    threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
    with pytest.raises(KeyboardInterrupt):
        _interruptible(lambda: released.wait(30))  # a call that would not return for 30 s
    released.set()


def test_a_close_zenoh_cannot_finish_is_left_to_a_daemon_thread_and_its_failure_unsaid(
    monkeypatch,
):
    """Across a cut link Zenoh's close waits ~10 s for the lost peer, then raises
    (eclipse-zenoh/zenoh#2675): the network waits CLOSE_WAIT_S at most, and the failure, with no
    one left to tell, is no traceback."""
    import threading

    from choreo.show import network as module

    monkeypatch.setattr(module, "CLOSE_WAIT_S", 0.05)
    unraised: list[object] = []
    monkeypatch.setattr(threading, "excepthook", unraised.append)
    network = Network(listen=[f"tcp/127.0.0.1:{_free_port()}"])
    session, release = network._session, threading.Event()

    class CutLink:
        def close(self) -> None:
            release.wait(30)
            session.close()
            raise zenoh.ZError("close operation timed out")

    network._session = CutLink()
    network.close()
    (closer,) = [thread for thread in threading.enumerate() if thread.name == "zenoh-close"]
    assert closer.daemon and closer.is_alive()  # returned while Zenoh still closes
    release.set()
    closer.join(30)
    assert not closer.is_alive() and unraised == []


def test_an_endpoint_that_cannot_be_listened_on_says_why_naming_listen(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        busy = taken.getsockname()[1]
        problems = {}
        for endpoint in (
            "tcp/192.0.2.1:7447",  # TEST-NET-1: no interface here has it
            "udp/192.0.2.1:7447",
            "tcp/nowhere.invalid:7447",  # .invalid never resolves (RFC 6761)
            f"tcp/127.0.0.1:{busy}",
            "tls/127.0.0.1:0",
            f"unixsock-stream/{tmp_path}/missing/x.sock",
        ):
            with pytest.raises(OptionError) as refused:
                Network(listen=[endpoint])
            assert refused.value.option == "listen"
            problems[endpoint] = refused.value.problem
    assert problems == {
        "tcp/192.0.2.1:7447": "'tcp/192.0.2.1:7447': 192.0.2.1 is not an address of this "
        "computer; give one of its own, or tcp/0.0.0.0:7447",
        "udp/192.0.2.1:7447": "'udp/192.0.2.1:7447': 192.0.2.1 is not an address of this "
        "computer; give one of its own, or udp/0.0.0.0:7447",
        "tcp/nowhere.invalid:7447": "'tcp/nowhere.invalid:7447': the host 'nowhere.invalid' "
        "does not resolve; give an address of this computer, or tcp/0.0.0.0:7447 for all of "
        "them",
        f"tcp/127.0.0.1:{busy}": f"'tcp/127.0.0.1:{busy}': port {busy} is in use there "
        "(another performer or program); choose another port",
        "tls/127.0.0.1:0": "'tls/127.0.0.1:0' needs this computer's TLS certificate and private "
        "key: name them in the Zenoh configuration given with zenoh_config (transport/link/tls: "
        "listen_certificate and listen_private_key), as docs/shows.md shows",
        f"unixsock-stream/{tmp_path}/missing/x.sock": f"'unixsock-stream/{tmp_path}/missing/"
        f"x.sock': the folder {tmp_path}/missing does not exist",
    }


def test_a_host_to_connect_to_that_does_not_resolve_is_refused_before_the_session_opens():
    with pytest.raises(OptionError) as refused:
        Network(connect=["tcp/nowhere.invalid:7447"])
    assert str(refused.value) == (
        "connect 'tcp/nowhere.invalid:7447': the host 'nowhere.invalid' does not resolve to an "
        "address"
    )
