"""Where the studio's page is served (its own module: the command line parses it without loading
the studio, and so without MuJoCo)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Address:
    """``host`` and ``port`` (0: any free port); with ``next_free`` (the default address, no
    port named) the next free port when ``port`` is taken."""

    host: str
    port: int
    next_free: bool = False

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"
