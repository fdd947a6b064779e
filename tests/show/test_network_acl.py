"""Zenoh's access control, as docs/shows.md writes it: the performer's configuration is the
doc's own ``access_control`` block (read from the doc) over mutual TLS. A session with a
certificate the show's CA signed, but not the conductor's common name, can neither stage, start
nor stop a part; the conductor's can."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from paths import REPO
from show_helpers import (
    Caller,
    Stage,
    eventually,
    make_certificates,
    sign_certificate,
    stage_stop_and_play,
    tls_config,
)

from choreo.show.network import Network

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")
DOC = REPO / "docs" / "shows.md"
REALM = "lab"  # the doc's key_exprs: choreo/lab/**
NO_ANSWER_S = 2.0  # how long a refused question waits before it counts as unanswered


def doc_access_control() -> str:
    """The JSON5 block of the doc's "Access control" section, as written there."""
    section = DOC.read_text().split("## Access control", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```json5\n(.*?)```", section, flags=re.DOTALL)
    assert len(blocks) == 1, "the doc's Access control section has one json5 block"
    assert blocks[0].lstrip().startswith("access_control:")
    return blocks[0]


@pytest.fixture(scope="module")
def certificates(tmp_path_factory):
    folder = tmp_path_factory.mktemp("acl")
    make_certificates(folder)
    sign_certificate(folder, "stranger")  # the show's CA signed it: TLS alone lets it in
    return folder


@pytest.fixture
def stage(certificates):
    tls = tls_config(certificates, "performer").read_text()  # {"transport": ...}
    config = certificates / "performer-acl.json5"
    config.write_text(tls.rstrip().removesuffix("}") + ",\n" + doc_access_control() + "}\n")
    stage = Stage(protocol="tls", zenoh_config=config, realm=REALM)
    yield stage
    stage.close()


def session(stage: Stage, certificates: Path, who: str) -> Network:
    return Network(
        connect=[stage.endpoint], zenoh_config=tls_config(certificates, who), realm=REALM
    )


def test_a_session_the_rules_do_not_allow_can_neither_stage_start_nor_stop(stage, certificates):
    with session(stage, certificates, "stranger") as stranger:
        impostor = Caller(stranger, "show-1")
        impostor.hold()
        try:
            assert impostor.info(timeout_s=NO_ANSWER_S) is None
            assert impostor.stage(timeout_s=NO_ANSWER_S) is None
            assert impostor.go(timeout_s=NO_ANSWER_S) is None
            impostor.stop()
        finally:
            impostor.fall_silent()
    assert stage.said == []  # no part staged or refused, no stop seen


def test_the_conductor_the_rules_allow_stages_starts_and_stops(stage, certificates):
    with session(stage, certificates, "conductor") as allowed:
        conductor = Caller(allowed, "show-1")
        eventually(lambda: conductor.info(timeout_s=NO_ANSWER_S), "the conductor reaches it")
        stage_stop_and_play(conductor, stage)
