"""The exceptions of the rig (§3.1, §4): bytes that break a protocol, devices that fail.

:class:`ProtocolError` is what the pure protocol functions
(:mod:`refsynth.acquisition.pan_protocol`,
:mod:`refsynth.acquisition.rangefinder_protocol`) raise on bytes that do not
follow the protocol; it is a :class:`ValueError` (bad input), and the drivers
turn it into a :class:`ReplyError`.

The drivers' exceptions derive from :class:`RigError`. Every one names the
device (``"pan unit"`` or ``"rangefinder"``) and the command, so that a
message reads on its own::

    rangefinder: GS0379024310;0007: status 02 (laser off)
    pan unit: PP600: ! Maximum allowable pan position exceeded

:class:`RigError` derives from :class:`OSError` (a device failing is an
input/output error), which the command line reports as one line with exit
status 2.

References
----------
Torres-Méndez & Dudek (2008), §3.1 and §4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

__all__ = [
    "ProtocolError",
    "RigError",
    "DeviceError",
    "ReplyError",
    "DeviceTimeout",
    "PortLost",
    "RetriesExhausted",
]


class ProtocolError(ValueError):
    """A reply (or command) that does not follow the protocol: reject it.

    Examples
    --------
    >>> from refsynth.acquisition.pan_protocol import parse_pan_reply
    >>> try:
    ...     parse_pan_reply(b"* abc\\r\\n", "int")
    ... except ProtocolError as error:
    ...     print(type(error).__name__, isinstance(error, ValueError))
    ProtocolError True
    """


class RigError(OSError):
    """A failure talking to a device of the rig.

    Attributes
    ----------
    device : str
        ``"pan unit"`` or ``"rangefinder"``.
    command : str
        The command as sent (terminator removed), or a short description.
    detail : str
        What went wrong.

    Examples
    --------
    >>> error = RigError("pan unit", "PP600", "! Maximum allowable pan position exceeded")
    >>> print(error)
    pan unit: PP600: ! Maximum allowable pan position exceeded
    >>> isinstance(error, OSError)
    True
    """

    def __init__(self, device: str, command: str, detail: str) -> None:
        self.device = device
        self.command = command
        self.detail = detail
        super().__init__(f"{device}: {command}: {detail}")

    def __str__(self) -> str:
        return f"{self.device}: {self.command}: {self.detail}"

    def __reduce__(self):
        return (type(self), (self.device, self.command, self.detail))


class DeviceError(RigError):
    """The device answered with an error (``! message`` or a non-zero status).

    Attributes
    ----------
    code : int or None
        The rangefinder's status code (None for the pan unit).
    message : str
        The pan unit's message, or the status code's meaning.
    transient : bool
        Whether the same request may well succeed if sent again.

    Examples
    --------
    >>> error = DeviceError("rangefinder", "GS0379024310", "status 02 (laser off)",
    ...                     code=2, message="laser off")
    >>> print(error)
    rangefinder: GS0379024310: status 02 (laser off)
    >>> error.code, error.transient
    (2, False)
    """

    def __init__(
        self, device: str, command: str, detail: str, *, code: int | None = None,
        message: str = "", transient: bool = False,
    ) -> None:
        super().__init__(device, command, detail)
        self.code = code
        self.message = message
        self.transient = transient

    def __reduce__(self):
        return (_rebuild_device_error, (self.device, self.command, self.detail, self.code,
                                        self.message, self.transient))


def _rebuild_device_error(device, command, detail, code, message, transient):
    return DeviceError(device, command, detail, code=code, message=message, transient=transient)


class ReplyError(RigError):
    """A reply that breaks the protocol (wrong echo, bad status, wrong length, CRC mismatch).

    Examples
    --------
    >>> print(ReplyError("rangefinder", "GS0379024310", "echo mismatch"))
    rangefinder: GS0379024310: echo mismatch
    """


class DeviceTimeout(RigError):
    """No complete reply before the command's deadline.

    Examples
    --------
    >>> print(DeviceTimeout("pan unit", "A", "no reply within 5.0 s"))
    pan unit: A: no reply within 5.0 s
    """


class PortLost(RigError):
    """The port failed (the device vanished), or could not be reopened.

    Examples
    --------
    >>> isinstance(PortLost("rangefinder", "open", "no such port"), RigError)
    True
    """


class RetriesExhausted(RigError):
    """The same request failed every time it was tried; ``__cause__`` holds the last failure.

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise DeviceTimeout("pan unit", "PP", "no reply within 1.0 s")
    ...     except DeviceTimeout as last:
    ...         raise RetriesExhausted("pan unit", "PP", "3 tries failed") from last
    ... except RetriesExhausted as error:
    ...     print(error, "|", error.__cause__)
    pan unit: PP: 3 tries failed | pan unit: PP: no reply within 1.0 s
    """
