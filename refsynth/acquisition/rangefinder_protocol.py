"""The rangefinder's wire protocol, as pure functions on bytes (§3.1, §4).

No port, no clock, no state: every function here maps bytes to values or
values to bytes, so the protocol is tested by round-trips and by feeding the
parser arbitrary bytes. ``refsynth/acquisition/PROTOCOL.md`` is the same
specification written for someone who wants to build a device adapter; the
driver is :class:`refsynth.acquisition.rangefinder.Rangefinder`.

The paper's AccuRange 4000 sweeps a vertical plane with a 45° mirror on a
2000-position encoder; one *slice* is a run of encoder positions, each the
mean of several samples (§4: 10). The commands are AccuRange-style, the
framing Hokuyo-SCIP-style.

A command is one line ending in LF, optionally tagged with ``;<tag>``
(1–16 characters ``[0-9A-Za-z]``) that the device echoes, so a reply can be
matched to its request: ``VV`` (version), ``BM`` (laser on), ``QT`` (laser
off), ``GS<seq:4><count:4><avg:2>`` (one slice: encoder positions
``seq … seq+count−1``, each the mean of ``avg`` samples). A reply is::

    <echo of the command line>\\n
    <status: two digits>\\n
    <data lines, 1–64 printable characters each>\\n      (status 00 only)
    =<CRC-16 of the data lines, 4 hex digits>\\n          (status 00 only)
    \\n

The CRC is ``binascii.crc_hqx(data, 0xFFFF)`` (CRC-16/CCITT-FALSE) over
every byte of the data lines, their LF terminators included (``FFFF`` when
there are none). Status codes: ``00`` ok, ``01`` bad parameter, ``02``
laser off, ``03`` encoder fault, ``04`` busy, ``05`` unknown command; an
error reply has no data and no CRC line. A ``GS`` reply's data is the
concatenation of ``count`` fixed-width samples of 6 upper-case hex digits,
4 for the range in millimetres (``0000`` = no return) and 2 for the
amplitude (0–255), cut into lines of 64 characters (the last one shorter).

References
----------
Torres-Méndez & Dudek (2008), §3.1 and §4, doi:10.1007/s11263-007-0108-2.
Hokuyo, *SCIP 2.0 communication protocol specification* (the
echo/status/data/checksum framing).
"""

from __future__ import annotations

import binascii
import re
from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_int
from refsynth.acquisition.errors import ProtocolError
from refsynth.acquisition.geometry import ENCODER_POSITIONS

__all__ = [
    "RANGEFINDER_COMMANDS",
    "STATUS",
    "TRANSIENT_STATUS",
    "LINE_WIDTH",
    "SAMPLE_WIDTH",
    "RangefinderCommand",
    "RangefinderReply",
    "crc16",
    "encode_rangefinder_command",
    "parse_rangefinder_command",
    "encode_samples",
    "decode_samples",
    "encode_rangefinder_reply",
    "parse_rangefinder_reply",
    "rangefinder_reply_length",
]

#: Rangefinder command names.
RANGEFINDER_COMMANDS = ("VV", "BM", "QT", "GS")
#: Status codes and their meaning.
STATUS = {
    0: "ok",
    1: "bad parameter",
    2: "laser off",
    3: "encoder fault",
    4: "busy",
    5: "unknown command",
}
#: Status codes worth retrying as they are.
TRANSIENT_STATUS = frozenset({3, 4})
#: Longest data line, characters (LF excluded).
LINE_WIDTH = 64
#: Characters per sample in a GS reply: 4 hex digits of range (mm), 2 of amplitude.
SAMPLE_WIDTH = 6

_TAG = re.compile(rb"[0-9A-Za-z]{1,16}")
_RF_COMMAND = re.compile(
    rb"(VV|BM|QT)(?:;([0-9A-Za-z]{1,16}))?"
    rb"|GS([0-9]{4})([0-9]{4})([0-9]{2})(?:;([0-9A-Za-z]{1,16}))?"
)
_STATUS_LINE = re.compile(rb"[0-9]{2}")
_CRC_LINE = re.compile(rb"=([0-9A-F]{4})")
_DATA_LINE = re.compile(rb"[\x20-\x7e]{1,64}")
_HEX_DIGITS = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)
_HEX_VALUE = np.full(256, -1, dtype=np.int16)
_HEX_VALUE[_HEX_DIGITS] = np.arange(16)


@dataclass(frozen=True)
class RangefinderCommand:
    """A parsed rangefinder command line.

    Attributes
    ----------
    name : str
        ``"VV"``, ``"BM"``, ``"QT"`` or ``"GS"``.
    seq, count, average : int or None
        The GS parameters (None for the other commands). Their values are
        not range-checked here: the device answers status 01 to a bad one.
    tag : str or None
        The ``;tag`` the device must echo.
    """

    name: str
    seq: int | None = None
    count: int | None = None
    average: int | None = None
    tag: str | None = None


@dataclass(frozen=True)
class RangefinderReply:
    """A parsed, validated rangefinder reply.

    Attributes
    ----------
    status : int
        0 for success, else a code of :data:`STATUS` (the reply then has no
        data).
    lines : tuple of bytes
        The data lines, LF removed.
    """

    status: int
    lines: tuple[bytes, ...] = ()

    @property
    def ok(self) -> bool:
        """``status == 0``."""
        return self.status == 0

    @property
    def payload(self) -> bytes:
        """The data lines concatenated (the GS samples)."""
        return b"".join(self.lines)


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: ``binascii.crc_hqx(data, 0xFFFF)``.

    Examples
    --------
    >>> f"{crc16(b'123456789'):04X}"
    '29B1'
    """
    return binascii.crc_hqx(bytes(data), 0xFFFF)


def encode_rangefinder_command(
    name: str,
    *,
    seq: int | None = None,
    count: int | None = None,
    average: int | None = None,
    tag: str | None = None,
) -> bytes:
    """The bytes of one rangefinder command line (LF-terminated).

    Parameters
    ----------
    name : {"VV", "BM", "QT", "GS"}
    seq, count, average : int
        GS only: first encoder position (0–1999), number of positions
        (1–2000, ``seq + count <= 2000``), samples averaged per position
        (1–99).
    tag : str, optional
        1–16 characters ``[0-9A-Za-z]``, echoed by the device.

    Examples
    --------
    >>> encode_rangefinder_command("GS", seq=379, count=243, average=10, tag="002A")
    b'GS0379024310;002A\\n'
    """
    if name not in RANGEFINDER_COMMANDS:
        raise ValueError(
            f"The parameter `name` must be one of {RANGEFINDER_COMMANDS}, got {name!r}"
        )
    text = name
    if name == "GS":
        seq = check_int("seq", seq, minimum=0, maximum=ENCODER_POSITIONS - 1)
        count = check_int("count", count, minimum=1, maximum=ENCODER_POSITIONS)
        average = check_int("average", average, minimum=1, maximum=99)
        if seq + count > ENCODER_POSITIONS:
            raise ValueError(
                f"The parameters `seq` + `count` must be <= {ENCODER_POSITIONS}, got {seq + count}"
            )
        text += f"{seq:04d}{count:04d}{average:02d}"
    elif (seq, count, average) != (None, None, None):
        raise ValueError(f"The rangefinder command {name} takes no parameters")
    if tag is not None:
        if not isinstance(tag, str) or _TAG.fullmatch(tag.encode("ascii", "replace")) is None:
            raise ValueError(
                f"The parameter `tag` must be 1-16 characters [0-9A-Za-z], got {tag!r}"
            )
        text += f";{tag}"
    return text.encode("ascii") + b"\n"


def parse_rangefinder_command(line: bytes) -> RangefinderCommand:
    """Parse one command line (terminator removed), as the device does.

    Raises
    ------
    ProtocolError
        If the line is not a known command with well-formed parameters.

    Examples
    --------
    >>> parse_rangefinder_command(b"GS0379024310;7")
    RangefinderCommand(name='GS', seq=379, count=243, average=10, tag='7')
    """
    match = _RF_COMMAND.fullmatch(bytes(line))
    if match is None:
        raise ProtocolError(f"not a rangefinder command: {bytes(line)[:24]!r}")
    if match.group(1) is not None:
        tag = match.group(2)
        return RangefinderCommand(match.group(1).decode(), tag=tag.decode() if tag else None)
    seq, count, average, tag = match.group(3, 4, 5, 6)
    return RangefinderCommand(
        "GS", int(seq), int(count), int(average), tag.decode() if tag else None
    )


def encode_samples(range_mm, amplitude) -> bytes:
    """A GS payload: per sample 4 hex digits of range (mm) then 2 of amplitude.

    Parameters
    ----------
    range_mm : array_like of int, shape (N,)
        0 … 65535; 0 means no return.
    amplitude : array_like of int, shape (N,)
        0 … 255.

    Examples
    --------
    >>> encode_samples([3898, 0], [124, 0])
    b'0F3A7C000000'
    """
    r = np.asarray(range_mm)
    a = np.asarray(amplitude)
    if r.ndim != 1 or a.shape != r.shape:
        raise ValueError(
            f"The parameters `range_mm` and `amplitude` must be 1-D of equal length, "
            f"got shapes {r.shape} and {a.shape}"
        )
    for name, values, high in (("range_mm", r, 0xFFFF), ("amplitude", a, 0xFF)):
        if values.size and (
            not np.issubdtype(values.dtype, np.integer) or values.min() < 0 or values.max() > high
        ):
            raise ValueError(f"The parameter `{name}` must hold integers in [0, {high}]")
    digits = np.empty((r.size, SAMPLE_WIDTH), dtype=np.uint8)
    digits[:, :4] = _HEX_DIGITS[(r.astype(np.int64)[:, None] >> np.array([12, 8, 4, 0])) & 0xF]
    digits[:, 4:] = _HEX_DIGITS[(a.astype(np.int64)[:, None] >> np.array([4, 0])) & 0xF]
    return digits.tobytes()


def decode_samples(payload: bytes, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Invert :func:`encode_samples`: ``(range_mm uint16, amplitude uint8)``.

    Raises
    ------
    ProtocolError
        If the payload does not hold exactly ``count`` samples of upper-case
        hex digits.

    Examples
    --------
    >>> r, a = decode_samples(b"0F3A7C000000", 2)
    >>> r.tolist(), a.tolist()
    ([3898, 0], [124, 0])
    """
    payload = bytes(payload)
    if len(payload) != SAMPLE_WIDTH * count:
        raise ProtocolError(
            f"expected {count} samples ({SAMPLE_WIDTH * count} characters), got {len(payload)}"
        )
    values = _HEX_VALUE[np.frombuffer(payload, dtype=np.uint8)].reshape(count, SAMPLE_WIDTH)
    if values.size and values.min() < 0:
        raise ProtocolError("sample data must be upper-case hex digits")
    values = values.astype(np.uint32)
    range_mm = (values[:, :4] << np.array([12, 8, 4, 0], dtype=np.uint32)).sum(axis=1)
    amplitude = (values[:, 4:] << np.array([4, 0], dtype=np.uint32)).sum(axis=1)
    return range_mm.astype(np.uint16), amplitude.astype(np.uint8)


def _data_block(lines: list[bytes]) -> bytes:
    return b"".join(line + b"\n" for line in lines)


def encode_rangefinder_reply(command: bytes, status: int = 0, data: bytes | list = b"") -> bytes:
    """A complete reply, as the device sends it.

    Parameters
    ----------
    command : bytes
        The command line as received (a trailing LF or CR is removed for
        the echo).
    status : int
        A code of :data:`STATUS`.
    data : bytes or list of bytes
        Status 0 only. Bytes (a GS payload) are cut into lines of 64
        characters; a list is taken as the data lines themselves.

    Examples
    --------
    >>> encode_rangefinder_reply(b"BM\\n")
    b'BM\\n00\\n=FFFF\\n\\n'
    >>> encode_rangefinder_reply(b"GS0379024310\\n", 2)
    b'GS0379024310\\n02\\n\\n'
    """
    echo = bytes(command).rstrip(b"\r\n")
    if status not in STATUS:
        raise ValueError(f"The parameter `status` must be one of {sorted(STATUS)}, got {status!r}")
    if status != 0:
        if data:
            raise ValueError("An error reply carries no data")
        return echo + b"\n" + f"{status:02d}".encode() + b"\n\n"
    if isinstance(data, (bytes, bytearray)):
        data = bytes(data)
        lines = [data[i : i + LINE_WIDTH] for i in range(0, len(data), LINE_WIDTH)]
    else:
        lines = [bytes(line) for line in data]
    for line in lines:
        if _DATA_LINE.fullmatch(line) is None:
            raise ValueError(f"A data line must hold 1-64 printable characters, got {line[:70]!r}")
    block = _data_block(lines)
    return echo + b"\n00\n" + block + f"={crc16(block):04X}\n\n".encode()


def rangefinder_reply_length(command: bytes) -> int | None:
    """Byte length of a *successful* reply to a GS command, or None for other commands.

    Examples
    --------
    >>> rangefinder_reply_length(b"GS0379024310\\n")
    1504
    """
    try:
        parsed = parse_rangefinder_command(bytes(command).rstrip(b"\r\n"))
    except ProtocolError:
        return None
    if parsed.name != "GS":
        return None
    chars = SAMPLE_WIDTH * parsed.count
    lines = -(-chars // LINE_WIDTH)
    echo = len(bytes(command).rstrip(b"\r\n")) + 1
    return echo + 3 + chars + lines + 6 + 1


def parse_rangefinder_reply(raw: bytes, command: bytes) -> RangefinderReply:
    """Parse and validate a complete rangefinder reply to ``command``.

    Checks, in order: the blank line at the end; no empty line inside; the
    echo equals the command line; the status is two digits and a known
    code; an error reply has nothing after its status; a success reply ends
    in a CRC line equal to the CRC of its data lines, which hold 1–64
    printable characters each; and a GS reply's data are lines of exactly
    64 characters (the last 1–64) holding ``count`` samples of hex digits.

    Parameters
    ----------
    raw : bytes
        Every byte from the first of the echo to the final blank line.
    command : bytes
        The command line that was sent (its terminator is ignored).

    Returns
    -------
    RangefinderReply
        A well-formed error reply comes back with its ``status``; the
        caller decides what to raise.

    Raises
    ------
    ProtocolError
        If anything is out of place. No other exception escapes, whatever
        the bytes.

    Examples
    --------
    >>> parse_rangefinder_reply(b"BM\\n00\\n=FFFF\\n\\n", b"BM\\n").ok
    True
    """
    raw = bytes(raw)
    echo = bytes(command).rstrip(b"\r\n")
    if not raw.endswith(b"\n\n"):
        raise ProtocolError("the reply does not end with a blank line")
    lines = raw[:-2].split(b"\n")
    if any(not line for line in lines):
        raise ProtocolError("the reply has an empty line before its end")
    if lines[0] != echo:
        raise ProtocolError(f"wrong echo: expected {echo[:30]!r}, got {lines[0][:30]!r}")
    if len(lines) < 2 or _STATUS_LINE.fullmatch(lines[1]) is None:
        raise ProtocolError("no status line")
    status = int(lines[1])
    if status not in STATUS:
        raise ProtocolError(f"unknown status {status:02d}")
    if status != 0:
        if len(lines) != 2:
            raise ProtocolError(f"status {status:02d} with data after it")
        return RangefinderReply(status=status)
    if len(lines) < 3:
        raise ProtocolError("no CRC line")
    data, crc_line = lines[2:-1], lines[-1]
    crc_match = _CRC_LINE.fullmatch(crc_line)
    if crc_match is None:
        raise ProtocolError(f"bad CRC line {crc_line[:10]!r}")
    for line in data:
        if _DATA_LINE.fullmatch(line) is None:
            raise ProtocolError(f"bad data line of {len(line)} characters")
    expected = crc16(_data_block(data))
    if int(crc_match.group(1), 16) != expected:
        raise ProtocolError(
            f"CRC mismatch: got {crc_match.group(1).decode()}, computed {expected:04X}"
        )
    try:
        parsed = parse_rangefinder_command(echo)
    except ProtocolError:
        parsed = None
    if parsed is not None and parsed.name == "GS":
        if any(len(line) != LINE_WIDTH for line in data[:-1]):
            raise ProtocolError("a GS data line other than the last is not 64 characters")
        decode_samples(b"".join(data), parsed.count)  # raises on a wrong length or a bad digit
    elif parsed is not None and parsed.name in ("BM", "QT") and data:
        raise ProtocolError(f"{parsed.name} reply with data")
    return RangefinderReply(status=0, lines=tuple(data))
