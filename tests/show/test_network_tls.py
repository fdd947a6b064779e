"""Zenoh's mutual TLS keeps strangers out: a performer listening on TLS with client certificates
required, certificates made here with openssl. The conductor's session (with its certificate)
stages, starts and stops; sessions without one can do none of it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from show_helpers import (
    Caller,
    Stage,
    eventually,
    make_certificates,
    stage_stop_and_play,
    tls_config,
)

from choreo.show.network import Network

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")
NO_ANSWER_S = 2.0  # how long a stranger's question waits before it counts as unanswered


@pytest.fixture(scope="module")
def certificates(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tls")
    make_certificates(folder)
    return folder


@pytest.fixture
def stage(certificates):
    stage = Stage(protocol="tls", zenoh_config=tls_config(certificates, "performer"))
    yield stage
    stage.close()


def stranger(stage: Stage, config: Path | None, endpoint: str | None = None) -> Network:
    return Network(connect=[endpoint or stage.endpoint], zenoh_config=config)


@pytest.mark.parametrize(
    "who",
    ["trusting the CA, without a certificate", "with a certificate of its own CA", "plain TCP"],
)
def test_a_session_without_the_certificate_can_neither_stage_start_nor_stop(
    stage, certificates, tmp_path, who
):
    if who == "plain TCP":
        session = stranger(stage, None, stage.endpoint.replace("tls/", "tcp/"))
    elif who == "with a certificate of its own CA":
        make_certificates(tmp_path)  # the same names, another CA; the show's CA trusted
        session = stranger(stage, tls_config(tmp_path, "conductor", trusting=certificates))
    else:
        session = stranger(stage, tls_config(certificates, None, mutual=False))
    with session:
        impostor = Caller(session)
        impostor.hold()
        try:
            assert impostor.info(timeout_s=NO_ANSWER_S) is None
            assert impostor.stage(timeout_s=NO_ANSWER_S) is None
            assert impostor.go(timeout_s=NO_ANSWER_S) is None
            impostor.stop()
        finally:
            impostor.fall_silent()
    # the conductor, with its certificate, is heard: the performer is idle and took nothing
    with Network(
        connect=[stage.endpoint], zenoh_config=tls_config(certificates, "conductor")
    ) as ok:
        conductor = Caller(ok, "show-2")
        eventually(lambda: conductor.info(timeout_s=NO_ANSWER_S), "the conductor reaches it")
        assert conductor.info().state == "idle"
    assert stage.said == []  # no part staged or refused, no stop seen


def test_the_conductor_with_its_certificate_stages_starts_and_stops(stage, certificates):
    config = tls_config(certificates, "conductor")
    with Network(connect=[stage.endpoint], zenoh_config=config) as session:
        conductor = Caller(session, "show-1")
        eventually(lambda: conductor.info(timeout_s=NO_ANSWER_S), "the conductor reaches it")
        stage_stop_and_play(conductor, stage)
