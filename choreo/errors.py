"""The whole exception tree of choreo, and the words it speaks to a user.

A bad argument to a public call is an ``OptionError`` (a ``ValueError`` too) naming the argument,
what was given and what would be valid (``choreo.core.arguments`` checks them). Everything a user
can run into at the edges is a ``ChoreoError``; the CLI prints its message as one line and exits
1, or 2 for a ``UsageError``.

Messages, notes and warnings speak of the library's arguments (``allow_past_song``). One that
names an argument is a :class:`Worded` text, which the CLI spells with its flags instead
(``--allow-past-song``): errors, notes and warnings alike.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any, Self

if TYPE_CHECKING:
    from choreo.bus.protocol import Command

NameOf = Callable[[str], str]  # an argument's name -> how to spell it (the CLI: its flag)


class Worded(str):
    """Words for a user that name library arguments. As a ``str`` they spell each name as the
    library does (``pass allow_past_song``); :meth:`worded` spells them another way, as the CLI
    does with its flags (``pass --allow-past-song``). ``template`` writes each argument as
    ``{name}``; ``names`` lists them."""

    template: str
    names: tuple[str, ...]

    def __new__(cls, template: str, names: Iterable[str]) -> Self:
        names = tuple(names)
        text = super().__new__(cls, _spelled(template, names, str))
        text.template, text.names = template, names
        return text

    def worded(self, name_of: NameOf) -> str:
        return _spelled(self.template, self.names, name_of)


def worded(text: str, name_of: NameOf) -> str:
    """``text`` with the arguments it names spelled by ``name_of``: a :class:`Worded` text
    reworded, any other as it is."""
    return text.worded(name_of) if isinstance(text, Worded) else str(text)


def joined(separator: str, texts: Iterable[str]) -> str:
    """``separator.join(texts)``, still :class:`Worded` where any of them is (``str.join`` and
    f-strings forget what a text names)."""
    texts = list(texts)
    if not any(isinstance(text, Worded) for text in texts):
        return separator.join(texts)
    names = dict.fromkeys(name for text in texts if isinstance(text, Worded) for name in text.names)
    template = separator.join(text.template if isinstance(text, Worded) else text for text in texts)
    return Worded(template, names)


def _spelled(template: str, names: Iterable[str], name_of: NameOf) -> str:
    """``template`` with each ``{name}`` of ``names`` replaced by ``name_of`` the name."""
    for name in names:
        template = template.replace("{" + name + "}", name_of(name))
    return template


class ChoreoError(Exception):
    """Base of every error choreo reports to a user.

    Its message may be :class:`Worded`: a message that tells how an argument would fix the
    problem is made with :meth:`naming`, ``option`` the argument (as the library spells it) and
    ``template`` the message with ``{option}`` where its name goes, so that the CLI can put its
    own flag there instead (with :meth:`worded`)."""

    option: str | None = None

    @classmethod
    def naming(cls, option: str, template: str, **data: Any) -> Self:
        error = cls(Worded(template.replace("{option}", "{" + option + "}"), (option,)), **data)
        error.option = option
        return error

    def worded(self, name_of: NameOf) -> str:
        """The message with the arguments it names spelled by ``name_of`` (e.g. as flags)."""
        return worded(self.args[0], name_of) if len(self.args) == 1 else str(self)


class OptionError(ChoreoError, ValueError):
    """An argument of a library call that cannot be used as given: ``option`` names it (as the
    call spells it, ``exit_pose``) and ``problem`` says what is wrong and what would be valid
    (where it names the argument again, it writes ``{option}``; another argument, ``{name}``,
    listed in ``mentions``). The CLI shows its own flags in the arguments' place
    (``--exit-pose``)."""

    option: str

    def __init__(self, option: str, problem: str, *, mentions: tuple[str, ...] = ()):
        names = (option, *mentions)
        template = problem.replace("{option}", "{" + option + "}")
        self.problem = _spelled(template, names, str)
        super().__init__(Worded("{" + option + "} " + template, names))
        self.option = option
        self.mentions = mentions


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
    """One or more problems in robot or motion files; each message starts ``path:line:col:``
    (a :class:`Worded` one where it names an argument)."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__(joined("\n", self.problems))


class PlanningError(ChoreoError):
    """A motion cannot be planned within the robot's limits; ``.problems`` lists every message
    (one per keyframe or joint concerned), as :class:`SourceError`'s does."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__(joined("\n", self.problems))


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
