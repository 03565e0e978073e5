"""The pan unit's wire protocol, as pure functions on bytes (§3.1, §4).

No port, no clock, no state: every function here maps bytes to values or
values to bytes, so the protocol is tested by round-trips and by feeding the
parser arbitrary bytes. ``refsynth/acquisition/PROTOCOL.md`` is the same
specification written for someone who wants to build a device adapter; the
driver is :class:`refsynth.acquisition.pan_unit.PanUnit`.

The paper's pan unit turns the rangefinder and the camera through 180° in
0.36° steps (§4). The commands follow the Directed Perception PTU ASCII
command set (terse, no echo). A command is a name, an optional decimal
argument, and a delimiter (the driver sends a space; the device accepts
space, CR or LF):

=========  ===========================  ========================================
command    meaning                      success reply
=========  ===========================  ========================================
``PR``     resolution                   ``* 1296.0000`` (seconds of arc/step)
``PN``     minimum position             ``* 0``
``PX``     maximum position             ``* 499``
``PP<n>``  absolute move to ``n``       ``*``
``PP``     current position             ``* <n>``
``PS<n>``  speed, positions per second  ``*``
``PS``     current speed                ``* <n>``
``A``      await the end of the move    ``*`` (sent when the move is done)
``R``      reset (re-home to 0)         ``*``
``V``      version                      ``* <text>``
``C``      take a picture               ``* <n>`` (the position it was taken at)
=========  ===========================  ========================================

Every reply is one line ending in CR LF: ``*`` or ``* <value>`` on success,
``! <message>`` on error. The pan protocol has no checksum: a corrupted
digit in a value cannot be detected, so the driver never trusts a single
reading (it confirms every move by querying the position).

References
----------
Torres-Méndez & Dudek (2008), §3.1 and §4, doi:10.1007/s11263-007-0108-2.
Directed Perception, *PTU Command Reference Manual* (the pan unit's
command names and reply syntax).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from refsynth._checks import check_int
from refsynth.acquisition.errors import ProtocolError

__all__ = [
    "PAN_COMMANDS",
    "PAN_RESOLUTION",
    "PanReply",
    "encode_pan_command",
    "parse_pan_command",
    "pan_reply_kind",
    "format_pan_reply",
    "format_pan_error",
    "parse_pan_reply",
]

#: Pan-unit command names, and whether each takes an optional integer argument.
PAN_COMMANDS = {
    "PR": False,
    "PN": False,
    "PX": False,
    "PP": True,
    "PS": True,
    "A": False,
    "R": False,
    "V": False,
    "C": False,
}
#: The pan unit's resolution reply: seconds of arc per position (0.36°).
PAN_RESOLUTION = 1296.0

_PAN_COMMAND = re.compile(rb"(PR|PN|PX|PP|PS|A|R|V|C)(-?[0-9]{1,6})?")
_PAN_VALUE = {
    "int": re.compile(rb"-?[0-9]{1,6}"),
    "float": re.compile(rb"-?[0-9]{1,6}\.[0-9]{1,6}"),
    "text": re.compile(rb"[\x21-\x7e][\x20-\x7e]{0,63}"),
}
_PAN_ERROR = re.compile(rb"! ([\x21-\x7e][\x20-\x7e]{0,79})\r\n")


@dataclass(frozen=True)
class PanReply:
    """A parsed pan-unit reply.

    Attributes
    ----------
    ok : bool
        ``True`` for ``*`` replies, ``False`` for ``!`` replies.
    value : int, float, str or None
        The value of a ``* <value>`` reply (None for a bare ``*`` and for
        errors).
    message : str or None
        The text of a ``! <message>`` reply.
    """

    ok: bool
    value: int | float | str | None = None
    message: str | None = None


def encode_pan_command(name: str, value: int | None = None) -> bytes:
    """The bytes of one pan-unit command: name, optional argument, a space.

    Parameters
    ----------
    name : str
        One of :data:`PAN_COMMANDS`.
    value : int, optional
        The argument of ``PP`` (absolute position) or ``PS`` (speed);
        without it, ``PP`` and ``PS`` are queries.

    Examples
    --------
    >>> encode_pan_command("PP", 250)
    b'PP250 '
    >>> encode_pan_command("A")
    b'A '
    """
    if name not in PAN_COMMANDS:
        raise ValueError(
            f"The parameter `name` must be one of {sorted(PAN_COMMANDS)}, got {name!r}"
        )
    if value is None:
        return name.encode("ascii") + b" "
    if not PAN_COMMANDS[name]:
        raise ValueError(f"The pan command {name} takes no argument, got {value!r}")
    value = check_int("value", value)
    if not -999_999 <= value <= 999_999:
        raise ValueError(f"The parameter `value` must have at most 6 digits, got {value}")
    return f"{name}{value}".encode("ascii") + b" "


def parse_pan_command(token: bytes) -> tuple[str, int | None]:
    """Split one pan-unit command token (delimiter removed) into name and argument.

    Raises
    ------
    ProtocolError
        If the token is not a known command, or carries an argument that
        the command does not take.

    Examples
    --------
    >>> parse_pan_command(b"PP250")
    ('PP', 250)
    """
    match = _PAN_COMMAND.fullmatch(bytes(token))
    if match is None:
        raise ProtocolError(f"unknown pan command {bytes(token)[:20]!r}")
    name = match.group(1).decode("ascii")
    if match.group(2) is None:
        return name, None
    if not PAN_COMMANDS[name]:
        raise ProtocolError(f"the pan command {name} takes no argument")
    return name, int(match.group(2))


def pan_reply_kind(name: str, value: int | None = None) -> str:
    """What a success reply to a command carries: ``"none"``, ``"int"``, ``"float"``, ``"text"``.

    Examples
    --------
    >>> pan_reply_kind("PP", 250), pan_reply_kind("PP")
    ('none', 'int')
    """
    if name == "PR":
        return "float"
    if name == "V":
        return "text"
    if name in ("PN", "PX", "C") or (name in ("PP", "PS") and value is None):
        return "int"
    return "none"


def format_pan_reply(value: int | float | str | None = None) -> bytes:
    """A success reply: ``*\\r\\n`` or ``* <value>\\r\\n`` (floats with 4 decimals).

    Examples
    --------
    >>> format_pan_reply(), format_pan_reply(1296.0)
    (b'*\\r\\n', b'* 1296.0000\\r\\n')
    """
    if value is None:
        return b"*\r\n"
    if isinstance(value, float):
        text = f"{value:.4f}"
    else:
        text = str(value)
    return b"* " + text.encode("ascii") + b"\r\n"


def format_pan_error(message: str) -> bytes:
    """An error reply: ``! <message>\\r\\n``.

    Examples
    --------
    >>> format_pan_error("Illegal command")
    b'! Illegal command\\r\\n'
    """
    return b"! " + message.encode("ascii") + b"\r\n"


def parse_pan_reply(raw: bytes, kind: str) -> PanReply:
    """Parse one pan-unit reply line (CR LF included).

    Parameters
    ----------
    raw : bytes
        The whole reply, ``*…\\r\\n`` or ``! …\\r\\n``.
    kind : {"none", "int", "float", "text"}
        What the command's success reply must carry
        (:func:`pan_reply_kind`).

    Returns
    -------
    PanReply
        ``ok=False`` with the message for a well-formed ``!`` reply.

    Raises
    ------
    ProtocolError
        For anything else: a value where none belongs or of the wrong
        syntax, a missing value, stray bytes, a missing CR LF.

    Examples
    --------
    >>> parse_pan_reply(b"* 250\\r\\n", "int")
    PanReply(ok=True, value=250, message=None)
    """
    raw = bytes(raw)
    if kind not in ("none", "int", "float", "text"):
        raise ValueError(f"The parameter `kind` must be none, int, float or text, got {kind!r}")
    error = _PAN_ERROR.fullmatch(raw)
    if error is not None:
        return PanReply(ok=False, message=error.group(1).decode("ascii"))
    if kind == "none":
        if raw != b"*\r\n":
            raise ProtocolError(f"expected '*\\r\\n', got {raw[:40]!r}")
        return PanReply(ok=True)
    if not (raw.startswith(b"* ") and raw.endswith(b"\r\n")):
        raise ProtocolError(f"expected '* <{kind}>\\r\\n', got {raw[:40]!r}")
    text = raw[2:-2]
    if _PAN_VALUE[kind].fullmatch(text) is None:
        raise ProtocolError(f"expected '* <{kind}>\\r\\n', got {raw[:40]!r}")
    value = text.decode("ascii")
    if kind == "int":
        return PanReply(ok=True, value=int(value))
    if kind == "float":
        return PanReply(ok=True, value=float(value))
    return PanReply(ok=True, value=value)
