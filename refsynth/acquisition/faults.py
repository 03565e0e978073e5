"""What goes wrong on the simulated rig's wire: the fault model (§4).

A complete scan of the paper's rig takes about 20 minutes (§4: 500 slices,
each an average of 10 samples); a driver that loses nothing in that time
must survive garbled, lost and refused replies and a device that vanishes
(these faults are the simulator's, not the paper's). :class:`Faults` says
how often each happens; the pseudo-terminal servers of
:mod:`refsynth.acquisition.simulator` inject them, drawing from their own
seeded generator, so the same seed meets the same faults. Its string form
is what ``python -m refsynth scan --faults`` takes::

    corrupt=0.05,drop=0.02,disconnect=1,delay=0.01

References
----------
Torres-Méndez & Dudek (2008), §4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from refsynth._checks import check_int, check_real, is_real

__all__ = ["Faults"]


@dataclass(frozen=True)
class Faults:
    """What goes wrong on the simulated wire (only replies are affected).

    Parameters
    ----------
    corrupt : float
        Fraction of replies corrupted, each in one of three ways with equal
        chance: one byte XOR-ed with a random non-zero value; 1–8 random
        bytes sent before the reply; the reply cut short.
    drop : float
        Fraction of replies not sent at all (the command was carried out).
    error : float
        Fraction of requests refused with a transient error, not carried
        out: ``! Busy`` from the pan unit, status 04 (busy) or 03 (encoder
        fault) from the rangefinder.
    delay : float
        Seconds before every reply.
    disconnect : int
        Number of disconnects: the devices take turns, the rangefinder
        first; a device's k-th disconnect (k = 1, 2, …) happens instead of
        the reply to its ``k · disconnect_after``-th request. The device
        "reboots" (laser off; pan position 0) and comes back on a new
        pseudo-terminal after ``RigSimulator(reconnect_delay=...)``.
    disconnect_after : int, default 40
        See ``disconnect``.

    Examples
    --------
    >>> Faults.parse("corrupt=0.05,drop=0.02,disconnect=1")
    Faults(corrupt=0.05, drop=0.02, error=0.0, delay=0.0, disconnect=1, disconnect_after=40)
    """

    corrupt: float = 0.0
    drop: float = 0.0
    error: float = 0.0
    delay: float = 0.0
    disconnect: int = 0
    disconnect_after: int = 40

    def __post_init__(self) -> None:
        for name in ("corrupt", "drop", "error"):
            value = getattr(self, name)
            if not is_real(value) or not 0.0 <= value <= 1.0:
                raise ValueError(f"The fault `{name}` must be a fraction in [0, 1], got {value!r}")
        if self.corrupt + self.drop + self.error > 1.0:
            raise ValueError("The faults `corrupt` + `drop` + `error` must add up to at most 1, "
                             f"got {self.corrupt + self.drop + self.error:g}")
        check_real("delay", self.delay, minimum=0, maximum=10)
        check_int("disconnect", self.disconnect, minimum=0)
        check_int("disconnect_after", self.disconnect_after, minimum=1)

    @classmethod
    def parse(cls, spec: str | None) -> Faults:
        """From ``"key=value,..."`` with keys corrupt, drop, error, delay, disconnect,
        disconnect_after; ``""``, ``"none"`` or None give no faults.

        Raises
        ------
        ValueError
            On an unknown key, a key given twice, or a bad value (the message
            names it).
        """
        if spec is not None and not isinstance(spec, str):
            raise TypeError(f"The fault specification must be a str, got {type(spec).__name__}")
        if spec is None or spec.strip().lower() in ("", "none"):
            return cls()
        values: dict = {}
        names = {f: t for f, t in cls.__annotations__.items()}
        for item in spec.split(","):
            key, sep, text = item.partition("=")
            key = key.strip()
            if not sep or key not in names:
                raise ValueError(f"unknown fault {item.strip()!r}: expected key=value with key in "
                                 f"{', '.join(names)}")
            if key in values:
                raise ValueError(f"the fault {key!r} is given twice in {spec.strip()!r}")
            try:
                values[key] = int(text) if key.startswith("disconnect") else float(text)
            except ValueError:
                raise ValueError(f"bad value for fault {key!r}: {text.strip()!r}") from None
        return cls(**values)

    def __str__(self) -> str:
        default = Faults()
        items = [f"{k}={v:g}" for k, v in asdict(self).items() if v != getattr(default, k)]
        return ",".join(items) or "none"

    @property
    def any(self) -> bool:
        """Whether any fault is set."""
        return self != Faults()
