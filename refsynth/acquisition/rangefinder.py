"""Driver for the laser rangefinder (§3.1, §4): AccuRange-style commands, SCIP-style framing.

The paper's AccuRange 4000 sweeps a vertical plane with a 45° mirror on a
2000-position encoder; one *slice* is a run of encoder positions, each the
mean of several samples (§4: 10). Commands and replies are specified in
:mod:`refsynth.acquisition.rangefinder_protocol` and ``refsynth/acquisition/PROTOCOL.md``.

Each request carries a fresh tag (``;<4 hex digits>``) that the device
echoes, so a late reply to an earlier request is never taken for the
current one. A reply is accepted only if its echo, status line, length and
CRC are right; otherwise the port is drained to the reply's blank line and
the request sent again (slice requests are idempotent).

References
----------
Torres-Méndez & Dudek (2008), §3.1 (Fig. 1) and §4 (the AccuRange 4000-LIR: a
45° mirror on a 2000-position encoder; a slice is an average of 10 samples),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import time

import numpy as np

from refsynth._checks import check_real
from refsynth.acquisition.errors import DeviceError, DeviceTimeout, ProtocolError, ReplyError
from refsynth.acquisition.link import Device
from refsynth.acquisition.rangefinder_protocol import (
    STATUS,
    TRANSIENT_STATUS,
    RangefinderReply,
    decode_samples,
    encode_rangefinder_command,
    parse_rangefinder_reply,
    rangefinder_reply_length,
)

__all__ = ["Rangefinder", "LASER_OFF"]

#: The status code for "laser off": recovered by switching the laser on (BM) and retrying.
LASER_OFF = 2
#: Longest reply to VV / BM / QT the driver reads, bytes.
MAX_SHORT_REPLY = 4096


class Rangefinder(Device):
    """The rangefinder on a serial port.

    Parameters
    ----------
    port, baudrate, timeout, retries, reconnect_timeout
        As for :class:`~refsynth.acquisition.link.Device`; the defaults are
        115200 baud, a 0.5 s timeout, 8 retries (the transient errors are
        status 02, laser off: the laser is switched on first; 03, encoder
        fault; 04, busy) and 10 s to reconnect.
    sweep_time : float, default 0.0
        Seconds per mirror revolution, at most 60: a GS request's deadline is
        ``timeout + average * sweep_time`` (the paper's slices took about
        2.4 s for 10 samples; the simulator answers at once).

    Examples
    --------
    >>> from refsynth.acquisition import RigSimulator
    >>> with RigSimulator(seed=0) as rig, Rangefinder(rig.laser_port) as laser:
    ...     version = laser.initialise()
    >>> version["PROD"]
    'AccuRange 4000 (simulated)'
    """

    name = "rangefinder"

    def __init__(self, port, *, baudrate: int = 115200, timeout: float = 0.5, retries: int = 8,
                 reconnect_timeout: float = 10.0, sweep_time: float = 0.0) -> None:
        sweep_time = check_real("sweep_time", sweep_time, minimum=0, maximum=60)
        super().__init__(port, baudrate=baudrate, timeout=timeout, retries=retries,
                         reconnect_timeout=reconnect_timeout)
        self.sweep_time = sweep_time
        self.info: dict[str, str] = {}
        self._tag = 0

    # ------------------------------------------------------------------ one exchange

    def request(self, name: str, *, seq: int | None = None, count: int | None = None,
                average: int | None = None) -> RangefinderReply:
        """Send one command and return its validated reply; no retry.

        Raises
        ------
        DeviceError
            On a well-formed reply with a non-zero status (``code`` holds it).
        ReplyError
            On a reply that breaks the protocol (after draining the port to
            the reply's blank line).
        DeviceTimeout
            Without a complete reply before the deadline.
        PortLost
            If the port fails.
        """
        self._tag = (self._tag + 1) % 0x10000
        command = encode_rangefinder_command(name, seq=seq, count=count, average=average,
                                             tag=f"{self._tag:04X}")
        text = command.decode("ascii").strip()
        allowed = self.timeout + (average * self.sweep_time if name == "GS" else 0.0)
        deadline = time.monotonic() + allowed
        self.stats.requests += 1
        link = self._link
        link.send(text, command)

        def incomplete(got: bytes) -> DeviceTimeout:
            return DeviceTimeout(self.name, text,
                                 f"no complete reply within {allowed:.2f} s ({len(got)} bytes)")

        def reject(got: bytes, why: str) -> ReplyError:
            if not got.endswith(b"\n\n"):  # the rest of the reply is still on its way
                link.drain(text, deadline, b"\n\n")
            return ReplyError(self.name, text, f"rejected reply: {why}")

        echo = link.read_until(text, deadline, b"\n", len(command) + 32)
        if not echo.endswith(b"\n"):
            if len(echo) < len(command) + 32:
                raise incomplete(echo)
            raise reject(echo, "echo line too long")
        if echo != command:
            raise reject(echo, f"wrong echo {echo[:40]!r}")
        status = link.read_until(text, deadline, b"\n", 4)
        if not status.endswith(b"\n"):
            if len(status) < 4:
                raise incomplete(echo + status)
            raise reject(status, f"bad status line {status!r}")
        expected = rangefinder_reply_length(command)
        if status == b"00\n" and expected is not None:
            rest = link.read_exact(text, deadline, expected - len(echo) - len(status))
            if len(rest) < expected - len(echo) - len(status):
                raise incomplete(echo + status + rest)
        else:
            limit = 1 if status != b"00\n" else MAX_SHORT_REPLY
            rest = link.read_until(text, deadline, b"\n" if limit == 1 else b"\n\n", limit)
            if not rest.endswith(b"\n"):
                if len(rest) < limit:
                    raise incomplete(echo + status + rest)
                raise reject(rest, "reply too long")
        raw = echo + status + rest
        try:
            reply = parse_rangefinder_reply(raw, command)
        except ProtocolError as error:
            raise reject(raw, str(error)) from None
        if not reply.ok:
            meaning = STATUS[reply.status]
            raise DeviceError(
                self.name, text, f"status {reply.status:02d} ({meaning})", code=reply.status,
                message=meaning,
                transient=reply.status in TRANSIENT_STATUS or reply.status == LASER_OFF,
            )
        return reply

    # ------------------------------------------------------------------ operations

    def _version_once(self) -> dict[str, str]:
        reply = self.request("VV")
        info = {}
        for line in reply.lines:
            key, _, value = line.decode("ascii").partition(":")
            info[key] = value
        return info

    def _initialise_once(self) -> None:
        self.info = self._attempts("VV", self._version_once, reconnect=False)
        self._attempts("BM", lambda: self.request("BM"), reconnect=False)

    def initialise(self) -> dict[str, str]:
        """Read the version (``VV``) and switch the laser on (``BM``).

        Returns
        -------
        dict
            The ``VV`` data lines as ``KEY: value`` (``VEND``, ``PROD``,
            ``FIRM``, ``PROT``, ``ENCO``).
        """
        self._attempts("initialise", self._initialise_once)
        return self.info

    def version(self) -> dict[str, str]:
        """The ``VV`` data lines as a dict."""
        return self._attempts("VV", self._version_once)

    def laser_on(self) -> None:
        """``BM``."""
        self._attempts("BM", lambda: self.request("BM"))

    def laser_off(self) -> None:
        """``QT``."""
        self._attempts("QT", lambda: self.request("QT"))

    def scan_slice(self, seq: int, count: int, average: int) -> tuple[np.ndarray, np.ndarray]:
        """One slice: ``GS<seq><count><average>``, validated, retried on failure.

        Parameters
        ----------
        seq : int
            First encoder position, 0–1999.
        count : int
            Number of positions, ``seq + count <= 2000``.
        average : int
            Samples averaged per position, 1–99.

        Returns
        -------
        range_mm : ndarray of shape (count,), uint16
            Millimetres; 0 = no return.
        amplitude : ndarray of shape (count,), uint8
        """
        # validate before anything is sent (encode raises ValueError / TypeError)
        encode_rangefinder_command("GS", seq=seq, count=count, average=average)

        def attempt() -> tuple[np.ndarray, np.ndarray]:
            try:
                reply = self.request("GS", seq=seq, count=count, average=average)
            except DeviceError as error:
                if error.code == LASER_OFF:
                    self.request("BM")
                raise
            return decode_samples(reply.payload, count)

        return self._attempts(f"GS{seq:04d}{count:04d}{average:02d}", attempt)
