"""The whole exception tree of choreo.

A bad argument to a public call is an ``OptionError`` (a ``ValueError`` too) naming the argument,
what was given and what would be valid (``choreo.core.arguments`` checks them). Everything a user
can run into at the edges is a ``ChoreoError``; the CLI prints its message as one line and exits
1, or 2 for a ``UsageError``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Self

if TYPE_CHECKING:
    from choreo.bus.protocol import Command


class ChoreoError(Exception):
    """Base of every error choreo reports to a user.

    A message that tells how an argument would fix the problem is made with :meth:`naming`:
    ``option`` is the argument (as the library spells it) and ``template`` the message with
    ``{option}`` where its name goes, so that the CLI can put its own flag there instead
    (with :meth:`worded`). ``mentions`` are other arguments the message names, each written
    ``{name}`` in the template."""

    option: str | None = None
    template: str | None = None
    mentions: tuple[str, ...] = ()

    @classmethod
    def naming(cls, option: str, template: str, **data: Any) -> Self:
        error = cls(template.replace("{option}", option), **data)
        error.option, error.template = option, template
        return error

    def worded(self, name_of: Callable[[str], str]) -> str:
        """The message with the arguments it names spelled by ``name_of`` (e.g. as flags)."""
        if self.option is None or self.template is None:
            return str(self)
        return _spelled(self.template, self.option, self.mentions, name_of)


class OptionError(ChoreoError, ValueError):
    """An argument of a library call that cannot be used as given: ``option`` names it (as the
    call spells it, ``exit_pose``) and ``problem`` says what is wrong and what would be valid
    (where it names the argument again, it writes ``{option}``; another argument, ``{name}``,
    listed in ``mentions``). The CLI shows its own flags in the arguments' place
    (``--exit-pose``)."""

    option: str

    def __init__(self, option: str, problem: str, *, mentions: tuple[str, ...] = ()):
        self.problem = _spelled(problem, option, mentions, str)
        super().__init__(f"{option} {self.problem}")
        self.option = option
        self.template = "{option} " + problem
        self.mentions = mentions


def _spelled(
    template: str, option: str, mentions: tuple[str, ...], name_of: Callable[[str], str]
) -> str:
    """``template`` with ``{option}`` and each ``{mention}`` replaced by ``name_of`` its name."""
    text = template.replace("{option}", name_of(option))
    for name in mentions:
        text = text.replace("{" + name + "}", name_of(name))
    return text


class UsageError(ChoreoError):
    """The command line asks for something that can't be done as written (a bad option value or
    combination); the CLI prints it as one line and exits 2, as argparse does."""


# --- the bus -----------------------------------------------------------------------------------
class BusError(ChoreoError):
    """Something went wrong talking to the servo bus: ``servo_id`` and ``command`` say with
    which servo and command, where one was concerned (``None`` otherwise)."""

    def __init__(
        self, message: str, *, servo_id: int | None = None, command: Command | None = None
    ):
        super().__init__(message)
        self.servo_id = servo_id
        self.command = command


class PortError(BusError):
    """The serial port could not be opened or was lost."""


class BusTimeoutError(BusError, TimeoutError):
    """A servo did not answer in time (after all retries)."""


class ProtocolError(BusError):
    """Bytes arrived that are not the expected reply (bad checksum, wrong length, wrong id)."""


class ServoFault(BusError):
    """A servo reports or shows a fault: over-temperature, voltage out of range, stall."""


# --- files, plans, previews, playback ----------------------------------------------------------
class SourceError(ChoreoError):
    """One or more problems in robot or motion files; each message starts ``path:line:col:``."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__("\n".join(self.problems))


class PlanningError(ChoreoError):
    """A motion cannot be planned within the robot's limits; ``.problems`` lists every message
    (one per keyframe or joint concerned), as :class:`SourceError`'s does."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__("\n".join(self.problems))


class PreviewError(ChoreoError):
    """Simulation or rendering failed, or a check found a problem."""


class PlaybackAborted(ChoreoError):
    """Playback stopped for safety (fault, lost servo, position error)."""


class UnsupportedByTransport(BusError):
    """The transport (a controller board between host and servos) cannot do this command; the
    message names the transport and what to use instead."""


# --- music -----------------------------------------------------------------------------------
class NoAudioOutput(ChoreoError):
    """There is no audio output to play the song on (no library, no device)."""
