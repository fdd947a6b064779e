"""Other tools' files: the vendor editor's action groups (.d6a), read into motions and written
from them (:mod:`~choreo.interop.d6a`)."""

from __future__ import annotations

from choreo.interop.d6a import export_d6a, import_d6a

__all__ = ["export_d6a", "import_d6a"]
