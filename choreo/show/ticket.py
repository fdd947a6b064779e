"""Which conductor holds a performer: the ticket it sent with the part.

A conductor makes one random ticket per run of a show and sends it with every part it stages
(a query, answered only by that performer's queryable). From then on the performer takes a start
only with that ticket, and a stop or a heartbeat only signed with it (HMAC-SHA256), so a session
that merely overheard the show's id (its progress keys carry it) can neither start, stop nor keep
alive a part it did not stage. This binds a part to its conductor; it does not keep strangers off
the network: that is Zenoh's TLS / user-password authentication and access control
(docs/shows.md).
"""

from __future__ import annotations

import hashlib
import hmac
import secrets


def new_ticket() -> str:
    return secrets.token_hex(16)


def signature(ticket: str, *fields: object) -> str:
    """The HMAC of ``fields`` under ``ticket``."""
    text = "\x1f".join(str(field) for field in fields)
    return hmac.new(ticket.encode(), text.encode(), hashlib.sha256).hexdigest()


def signed(ticket: str, given: str, *fields: object) -> bool:
    """Whether ``given`` is the signature of ``fields`` under ``ticket`` (in constant time)."""
    return hmac.compare_digest(signature(ticket, *fields), given)
