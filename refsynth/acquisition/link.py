"""The serial link under both drivers: deadlines, draining, retries, reconnection (§3.1, §4).

:class:`Link` wraps one pyserial port. It never asks how many bytes are
waiting (``in_waiting`` is not available, or not meaningful, on every
pyserial URL handler): it reads a line up to a terminator, or an exact
number of bytes, each within the time left before the command's deadline.
Before each request it discards whatever is in the input buffer.

:class:`Device` is the base of :class:`~refsynth.acquisition.pan_unit.PanUnit` and
:class:`~refsynth.acquisition.rangefinder.Rangefinder`: it runs an operation again
(up to ``retries`` times) after a rejected reply, a timeout or a transient
device error, and after a lost port it reopens the port with exponential
backoff, re-initialises the device and tries again. Only idempotent
operations (absolute moves, slice requests) are retried.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import TypeVar

import serial

from refsynth._checks import check_int, check_real
from refsynth.acquisition.errors import (
    DeviceError,
    DeviceTimeout,
    PortLost,
    ReplyError,
    RetriesExhausted,
    RigError,
)

try:  # termios.error is not an OSError; pyserial lets it escape from a dead pty
    import termios

    _PORT_ERRORS: tuple[type[BaseException], ...] = (serial.SerialException, OSError, termios.error)
except ImportError:  # pragma: no cover - Windows
    _PORT_ERRORS = (serial.SerialException, OSError)

__all__ = ["open_port", "Link", "Device", "DeviceStats"]

T = TypeVar("T")

#: How long a drain after a rejected reply may wait for the rest of it, seconds.
DRAIN_TIMEOUT = 0.1
#: After a failed exchange, input is dropped until none arrives for this long (seconds), for
#: at most SETTLE_LIMIT: a late reply would otherwise answer the next request.
SETTLE_QUIET, SETTLE_LIMIT = 0.03, 1.0
#: First and longest wait between attempts to reopen a lost port, seconds.
BACKOFF_FIRST, BACKOFF_MAX = 0.05, 1.0
#: Reconnections allowed within one operation.
MAX_RECONNECTS = 3
#: The largest deadline (``timeout``, ``reconnect_timeout``), seconds; retries; baud rate.
MAX_SECONDS, MAX_RETRIES, MAX_BAUD = 3600.0, 1000, 10**8


def open_port(url: str, *, baudrate: int, timeout: float) -> serial.SerialBase:
    """Open a port by name or URL with exclusive access where the handler supports it.

    ``serial.serial_for_url(url, baudrate=..., timeout=..., exclusive=True)``;
    handlers that refuse ``exclusive`` (with ValueError or TypeError) are
    opened without it.
    """
    try:
        return serial.serial_for_url(url, baudrate=baudrate, timeout=timeout, exclusive=True)
    except (ValueError, TypeError):
        return serial.serial_for_url(url, baudrate=baudrate, timeout=timeout)


@dataclass
class DeviceStats:
    """Counters of one driver's traffic.

    Attributes
    ----------
    requests : int
        Requests sent.
    retries : int
        Operations sent again after a failure.
    rejected : int
        Replies rejected (wrong echo, bad status line, wrong length, CRC).
    timeouts : int
        Requests without a complete reply before their deadline.
    device_errors : int
        Transient error replies that were retried (busy, encoder fault,
        laser off).
    reconnects : int
        Ports lost and reopened.
    """

    requests: int = 0
    retries: int = 0
    rejected: int = 0
    timeouts: int = 0
    device_errors: int = 0
    reconnects: int = 0

    @property
    def faults(self) -> int:
        """Failures met and recovered from (or not yet given up on)."""
        return self.rejected + self.timeouts + self.device_errors + self.reconnects

    def as_dict(self) -> dict:
        """The counters as a dict (``faults`` included)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["faults"] = self.faults
        return out


class Link:
    """One serial port, read with deadlines.

    Parameters
    ----------
    port : str, os.PathLike or serial.SerialBase
        A port name or pyserial URL (``/dev/ttyUSB0``, ``loop://``, a pty
        path) to open, or an open pyserial port (anything with ``read``,
        ``read_until``, ``write``, ``reset_input_buffer`` and a settable
        ``timeout``).
    device : str
        The device's name for error messages.
    baudrate : int
    timeout : float
        Default read timeout while the port is idle, seconds.
    """

    def __init__(self, port, device: str, *, baudrate: int, timeout: float) -> None:
        self.device = device
        self.baudrate = baudrate
        self.idle_timeout = timeout
        if isinstance(port, (str, os.PathLike)):
            self.url: str | None = os.fspath(port)
            self.port = self._open()
            self.owned = True
        else:
            missing = [name for name in ("read", "read_until", "write", "reset_input_buffer")
                       if not callable(getattr(port, name, None))]
            if missing:
                raise TypeError(
                    f"The parameter `port` must be a port name, a URL or an open pyserial port, "
                    f"got {type(port).__name__} (no {', '.join(missing)})"
                )
            self.url = None
            self.port = port
            self.owned = False

    def _open(self):
        try:
            return open_port(self.url, baudrate=self.baudrate, timeout=self.idle_timeout)
        except (*_PORT_ERRORS, ValueError) as error:
            raise PortLost(self.device, f"open {self.url}", str(error)) from error

    @property
    def name(self) -> str:
        """The port's name or URL, for messages."""
        return self.url or str(getattr(self.port, "port", None) or type(self.port).__name__)

    def close(self) -> None:
        """Close the port if this link opened it."""
        if self.owned:
            try:
                self.port.close()
            except _PORT_ERRORS:
                pass

    def reopen(self) -> None:
        """Close and open again (by URL, or with the port object's own ``open``)."""
        try:
            self.port.close()
        except _PORT_ERRORS:
            pass
        if self.url is not None:
            self.port = self._open()
            return
        if not callable(getattr(self.port, "open", None)):
            raise PortLost(self.device, "reopen", f"the port {self.name} cannot be reopened")
        try:
            self.port.open()
        except _PORT_ERRORS as error:
            raise PortLost(self.device, f"reopen {self.name}", str(error)) from error

    # ------------------------------------------------------------------ I/O

    def send(self, command: str, data: bytes) -> None:
        """Discard pending input, then write ``data``."""
        try:
            self.port.reset_input_buffer()
            self.port.write(data)
        except serial.SerialTimeoutException as error:
            raise DeviceTimeout(self.device, command, f"write timed out: {error}") from error
        except _PORT_ERRORS as error:
            raise PortLost(self.device, command, f"port {self.name} failed: {error}") from error

    def _set_timeout(self, command: str, deadline: float) -> None:
        try:
            self.port.timeout = max(deadline - time.monotonic(), 0.0)
        except _PORT_ERRORS as error:
            raise PortLost(self.device, command, f"port {self.name} failed: {error}") from error

    def read_until(self, command: str, deadline: float, terminator: bytes, limit: int) -> bytes:
        """Bytes up to and including ``terminator``, at most ``limit`` of them.

        Returns what arrived before the deadline: the caller checks for the
        terminator (a short result means a timeout, a full one without the
        terminator a reply too long).
        """
        self._set_timeout(command, deadline)
        try:
            return bytes(self.port.read_until(terminator, limit))
        except _PORT_ERRORS as error:
            raise PortLost(self.device, command, f"port {self.name} failed: {error}") from error

    def read_exact(self, command: str, deadline: float, size: int) -> bytes:
        """Exactly ``size`` bytes, or fewer if the deadline passes first."""
        self._set_timeout(command, deadline)
        try:
            return bytes(self.port.read(size))
        except _PORT_ERRORS as error:
            raise PortLost(self.device, command, f"port {self.name} failed: {error}") from error

    def settle(self, quiet: float) -> None:
        """Drop input until ``quiet`` seconds pass without a byte (at most :data:`SETTLE_LIMIT`).

        After a timeout or a rejected reply, the replies still in flight (late,
        or to the commands of the failed exchange) would answer the next
        request, and a link whose every exchange sends several commands would
        stay one reply behind through all its retries; clearing the input
        before sending is not enough, as they arrive after it. A port that
        fails here is left for the next attempt to meet.
        """
        end = time.monotonic() + SETTLE_LIMIT
        try:
            while time.monotonic() < end:
                self.port.timeout = quiet
                if not self.port.read(65536):
                    return
        except _PORT_ERRORS:
            return

    def drain(self, command: str, deadline: float, terminator: bytes) -> None:
        """Read and drop the rest of a rejected reply, up to ``terminator`` (bounded in time)."""
        self.read_until(command, min(deadline, time.monotonic() + DRAIN_TIMEOUT), terminator, 65536)


class Device:
    """Retries, reconnection and statistics shared by the two drivers.

    Subclasses set :attr:`name` and implement :meth:`_initialise_once`;
    their defaults (baud rate, timeout, retries) are their own.

    Parameters
    ----------
    port : str, os.PathLike or serial.SerialBase
        A port name or pyserial URL, opened with
        ``serial.serial_for_url(url, baudrate=..., timeout=..., exclusive=True)``,
        or an open port (which the driver will not close).
    baudrate : int
        At most 10**8.
    timeout : float
        Deadline of one request, seconds, at most 3600.
    retries : int
        At most 1000: times a request is sent again after a rejected reply,
        a timeout or a transient device error.
    reconnect_timeout : float
        How long to keep trying to reopen a lost port, seconds, at most 3600.
    """

    #: The device's name in messages.
    name = "device"

    def __init__(self, port, *, baudrate: int, timeout: float, retries: int,
                 reconnect_timeout: float) -> None:
        # bounded: beyond an hour a deadline is no deadline (and overflows the clock at 1e300)
        self.timeout = check_real("timeout", timeout, positive=True, maximum=MAX_SECONDS)
        self.reconnect_timeout = check_real("reconnect_timeout", reconnect_timeout,
                                            positive=True, maximum=MAX_SECONDS)
        self.retries = check_int("retries", retries, minimum=0, maximum=MAX_RETRIES)
        check_int("baudrate", baudrate, minimum=1, maximum=MAX_BAUD)
        self.stats = DeviceStats()
        self._link = Link(port, self.name, baudrate=baudrate, timeout=self.timeout)

    # ------------------------------------------------------------------ lifetime

    @property
    def port(self):
        """The underlying pyserial port."""
        return self._link.port

    def close(self) -> None:
        """Close the port if the driver opened it (from a name or URL)."""
        self._link.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ subclass hooks

    def _initialise_once(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    # ------------------------------------------------------------------ retries

    def _attempts(self, command: str, attempt: Callable[[], T], *, reconnect: bool = True) -> T:
        """Run ``attempt`` until it succeeds: at most ``1 + retries`` tries.

        Rejected replies, timeouts and transient device errors are retried;
        a lost port is reopened (with backoff) and the device re-initialised
        before the next try, without using up a retry (at most
        :data:`MAX_RECONNECTS` times). Permanent device errors are raised at
        once.
        """
        failures = 0
        reconnects = 0
        while True:
            try:
                return attempt()
            except DeviceError as error:
                if not error.transient:
                    raise
                self.stats.device_errors += 1
                last: RigError = error
            except ReplyError as error:
                self.stats.rejected += 1
                last = error
            except DeviceTimeout as error:
                self.stats.timeouts += 1
                last = error
            except PortLost:
                if not reconnect or reconnects >= MAX_RECONNECTS:
                    raise
                reconnects += 1
                self.reconnect()
                continue
            failures += 1
            if failures > self.retries:
                raise RetriesExhausted(
                    self.name, command, f"failed {failures} times; last: {last.detail}"
                ) from last
            self.stats.retries += 1
            if not isinstance(last, DeviceError):  # a reply may still be on its way
                self._link.settle(min(self.timeout, SETTLE_QUIET))

    def reconnect(self) -> None:
        """Reopen the lost port with exponential backoff and re-initialise the device.

        Raises
        ------
        PortLost
            If the port cannot be reopened and the device re-initialised
            within ``reconnect_timeout`` seconds.
        """
        deadline = time.monotonic() + self.reconnect_timeout
        delay = BACKOFF_FIRST
        while True:
            try:
                self._link.reopen()
                self._initialise_once()
                self.stats.reconnects += 1
                return
            except RigError as error:
                last = error
            if time.monotonic() + delay > deadline:
                raise PortLost(
                    self.name, "reconnect",
                    f"could not reopen {self._link.name} within {self.reconnect_timeout:g} s; "
                    f"last: {last.detail}",
                ) from last
            time.sleep(delay)
            delay = min(2 * delay, BACKOFF_MAX)
