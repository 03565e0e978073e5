"""Driver for the pan unit (§3.1, §4): PTU-style ASCII commands over pyserial.

The paper's pan unit turns the rangefinder and the camera through 180° in
0.36° steps (500 positions). Commands and replies are specified in
:mod:`refsynth.acquisition.pan_protocol` and ``refsynth/acquisition/PROTOCOL.md``.

Every move is absolute (``PP<n>``), so sending it again after a lost or
garbled reply is safe; a move counts as done only when the unit, asked
for its position (``PP``), answers the target. The protocol has no
checksum, so this confirmation is what guards the slice ↔ position
association against a corrupted reply.

References
----------
Torres-Méndez & Dudek (2008), §3.1 and §4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from refsynth._checks import check_int
from refsynth.acquisition.errors import DeviceError, DeviceTimeout, ProtocolError, ReplyError
from refsynth.acquisition.link import Device
from refsynth.acquisition.pan_protocol import encode_pan_command, pan_reply_kind, parse_pan_reply

__all__ = ["PanUnit", "PanInfo", "TRANSIENT_MESSAGES"]

#: A ``!`` reply whose message starts with one of these is worth retrying.
TRANSIENT_MESSAGES = ("Busy",)
#: Longest reply line the driver reads, bytes.
MAX_REPLY = 128


@dataclass(frozen=True)
class PanInfo:
    """What :meth:`PanUnit.initialise` learned from the unit (§4: 0.36° steps over 180°).

    Attributes
    ----------
    version : str
        The ``V`` reply.
    resolution : float
        Seconds of arc per position (``PR``; 1296 = 0.36°).
    minimum, maximum : int
        Position limits (``PN``, ``PX``).
    speed : int
        Positions per second (``PS``).

    Examples
    --------
    >>> from refsynth.acquisition import RigSimulator
    >>> with RigSimulator(seed=0) as rig, PanUnit(rig.pan_port) as pan:
    ...     info = pan.initialise()
    >>> info.resolution / 3600, info.minimum, info.maximum
    (0.36, 0, 499)
    """

    version: str
    resolution: float
    minimum: int
    maximum: int
    speed: int


class PanUnit(Device):
    """The pan unit on a serial port.

    Parameters
    ----------
    port, baudrate, timeout, retries, reconnect_timeout
        As for :class:`~refsynth.acquisition.link.Device`; the defaults are
        9600 baud, a 0.5 s timeout (a move's ``A`` gets more: the travel time
        at the unit's speed), 8 retries (the transient error is ``! Busy``)
        and 10 s to reconnect.
    speed : int, optional
        Positions per second to set at initialisation (``PS<n>``); default:
        leave the unit's.

    Examples
    --------
    >>> from refsynth.acquisition import RigSimulator        # doctest: +SKIP
    >>> with RigSimulator(seed=0) as rig, PanUnit(rig.pan_port) as pan:  # doctest: +SKIP
    ...     pan.initialise().maximum
    ...     pan.move_to(250)
    499
    """

    name = "pan unit"

    def __init__(self, port, *, baudrate: int = 9600, timeout: float = 0.5, retries: int = 8,
                 reconnect_timeout: float = 10.0, speed: int | None = None) -> None:
        super().__init__(port, baudrate=baudrate, timeout=timeout, retries=retries,
                         reconnect_timeout=reconnect_timeout)
        self._speed_setting = speed
        self.info: PanInfo | None = None
        # where the unit can be: between the last confirmed position and every target sent
        # since (None: unknown, e.g. after a reset or a reconnection)
        self._possible: tuple[int, int] | None = None
        self._target: int | None = None

    # ------------------------------------------------------------------ one exchange

    def exchange(self, name: str, value: int | None = None):
        """Send one command and return the value of its reply; no retry.

        Parameters
        ----------
        name : str
            A pan command (``"PP"``, ``"A"``, …).
        value : int, optional
            Its argument.

        Returns
        -------
        int, float, str or None
            The reply's value (None for a bare ``*``).

        Raises
        ------
        DeviceError
            On a ``! message`` reply.
        ReplyError
            On a reply that breaks the protocol.
        DeviceTimeout
            Without a complete reply before the deadline.
        PortLost
            If the port fails.
        """
        command = encode_pan_command(name, value)
        text = command.decode("ascii").strip()
        deadline = time.monotonic() + self._deadline(name)
        self.stats.requests += 1
        self._link.send(text, command)
        raw = self._link.read_until(text, deadline, b"\n", MAX_REPLY)
        if not raw.endswith(b"\n"):
            if len(raw) >= MAX_REPLY:
                self._link.drain(text, deadline, b"\n")
                raise ReplyError(self.name, text, f"reply longer than {MAX_REPLY} bytes")
            got = f" (got {raw[:40]!r})" if raw else ""
            raise DeviceTimeout(
                self.name, text, f"no complete reply within {self._deadline(name):.2f} s{got}"
            )
        try:
            reply = parse_pan_reply(raw, pan_reply_kind(name, value))
        except ProtocolError as error:
            raise ReplyError(self.name, text, f"rejected reply {raw[:40]!r}: {error}") from None
        if not reply.ok:
            transient = reply.message.startswith(TRANSIENT_MESSAGES)
            raise DeviceError(self.name, text, f"! {reply.message}", message=reply.message,
                              transient=transient)
        if name == "PP" and value is not None:
            self._target = value
            if self._possible is not None:
                self._possible = (min(self._possible[0], value), max(self._possible[1], value))
        elif name == "PP":
            self._possible = (reply.value, reply.value)
        elif name == "R":
            self._possible = None
        return reply.value

    def _deadline(self, name: str) -> float:
        """The timeout, plus the travel time at the unit's speed for ``A`` and ``R``."""
        if name in ("A", "R") and self.info is not None and self.info.speed > 0:
            travel = self.info.maximum - self.info.minimum
            if name == "A" and self._possible is not None and self._target is not None:
                low, high = self._possible
                travel = max(abs(self._target - low), abs(self._target - high))
            return self.timeout + 1.5 * travel / self.info.speed
        return self.timeout

    # ------------------------------------------------------------------ operations

    def _initialise_once(self) -> None:
        self._possible = None  # a unit that was lost may have been reset
        version = self._attempts("V", lambda: self.exchange("V"), reconnect=False)
        resolution = self._attempts("PR", lambda: self.exchange("PR"), reconnect=False)
        minimum = self._attempts("PN", lambda: self.exchange("PN"), reconnect=False)
        maximum = self._attempts("PX", lambda: self.exchange("PX"), reconnect=False)
        if self._speed_setting is not None:
            self._attempts(f"PS{self._speed_setting}",
                           lambda: self.exchange("PS", self._speed_setting), reconnect=False)
        speed = self._attempts("PS", lambda: self.exchange("PS"), reconnect=False)
        if maximum < minimum:
            raise ReplyError(self.name, "PX", f"limits {minimum} > {maximum}")
        self.info = PanInfo(str(version), float(resolution), int(minimum), int(maximum),
                            int(speed))

    def initialise(self) -> PanInfo:
        """Read the version, resolution, limits and speed (``V``, ``PR``, ``PN``, ``PX``, ``PS``).

        Sets the speed first if the driver was given one. Retries like every
        operation; reconnects on a lost port.
        """
        self._attempts("initialise", self._initialise_once)
        return self.info

    def _check_index(self, index) -> int:
        """``index`` as an int within the unit's limits (before ``initialise``: 0–499)."""
        index = check_int("index", index)
        low, high = (self.info.minimum, self.info.maximum) if self.info else (0, 499)
        if not low <= index <= high:
            raise ValueError(f"The parameter `index` must be in [{low}, {high}], got {index}")
        return index

    def move_to(self, index: int) -> None:
        """Move to an absolute position and wait until the unit is there.

        ``PP<index>``, then ``A``, then ``PP`` must answer ``index``; the
        whole sequence is retried on any failure (it is idempotent).

        Raises
        ------
        ValueError
            If ``index`` is outside the unit's limits (checked before
            sending anything).
        DeviceError, RetriesExhausted, PortLost
            If the move cannot be made.
        """
        index = self._check_index(index)

        def attempt() -> None:
            self.exchange("PP", index)
            self.exchange("A")
            position = self.exchange("PP")
            if position != index:
                raise ReplyError(self.name, f"PP{index}",
                                 f"the unit reports position {position} after the move")

        self._attempts(f"PP{index}", attempt)

    def position(self) -> int:
        """The current position (``PP`` query), retried on failure."""
        return int(self._attempts("PP", lambda: self.exchange("PP")))

    def trigger_camera(self, expected: int | None = None) -> int:
        """Take a picture (``C``); returns the position the unit reports it was taken at.

        Parameters
        ----------
        expected : int, optional
            If given, a reply naming another position is rejected and the
            trigger sent again.
        """

        def attempt() -> int:
            at = int(self.exchange("C"))
            if expected is not None and at != expected:
                raise ReplyError(self.name, "C", f"picture taken at {at}, expected {expected}")
            return at

        return self._attempts("C", attempt)

    def reset(self) -> None:
        """Reset the unit (``R``: re-home to position 0)."""
        self._attempts("R", lambda: self.exchange("R"))
