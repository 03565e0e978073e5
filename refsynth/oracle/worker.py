"""The function under test runs in a worker process: nothing it does can end or hang the check.

:class:`Runner` starts one worker process per check (:func:`start_method`: for a callable
``fork`` where the platform has it, so any callable works; else the platform's default,
which needs an importable ``MODULE:FUNCTION`` or a picklable function), imports the function
there, and sends it the cases one by one. Each call gets the time limit; a call that overruns
it, or that ends the worker (``os._exit``, a crash in C code), is that case's finding, and a
fresh worker takes the next case.

What comes back is an :class:`Outcome`: the result as numeric arrays, None (the kind is not
handled), or what went wrong in words: ``sys.exit``/``SystemExit`` (any code, 0 too), an
exception (with the file and line it came from), a result that is not a dict of numeric
arrays (a string, None, an object or ragged array, under which key), the time limit, a
worker that died.

With ``timeout=None`` the function runs in this process instead (no time limit, for a
debugger); ``SystemExit`` and exceptions are still caught.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import traceback
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["DEFAULT_TIMEOUT", "Outcome", "Runner", "check_timeout", "resolve_function",
           "start_method"]

#: Seconds one case's call may take (``oracle check --timeout``): room for a port in plain
#: Python, which may be many times slower than the literal reference on the largest cases.
DEFAULT_TIMEOUT = 120.0
#: The largest time limit accepted, in seconds (a week).
MAX_TIMEOUT = 7 * 24 * 3600.0


@dataclass(frozen=True)
class Outcome:
    """What one call gave: ``kind`` ``"result"`` (``value``: dict of arrays), ``"none"``,
    or a failure (``"raised"``, ``"exited"``, ``"result-type"``, ``"array"``,
    ``"timeout"``, ``"died"``) with ``text``, the finding in words."""

    kind: str
    value: dict | None = None
    text: str = ""


def check_timeout(timeout) -> float | None:
    """``timeout`` as seconds (None: no limit); ValueError/TypeError naming it otherwise.

    >>> check_timeout(2), check_timeout(None)
    (2.0, None)
    >>> check_timeout(0)
    Traceback (most recent call last):
    ValueError: The time limit `timeout` must be a number of seconds > 0 and <= 604800, got 0
    """
    if timeout is None:
        return None
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float, np.integer,
                                                             np.floating)):
        raise TypeError(f"The time limit `timeout` must be a number of seconds, got {timeout!r}")
    if not (math.isfinite(timeout) and 0 < timeout <= MAX_TIMEOUT):
        raise ValueError("The time limit `timeout` must be a number of seconds > 0 and "
                         f"<= {MAX_TIMEOUT:g}, got {timeout!r}")
    return float(timeout)


def _where(error: BaseException) -> str:
    """`` (file.py, line N)``: the innermost frame the exception came from."""
    frames = traceback.extract_tb(error.__traceback__)
    if not frames:
        return ""
    frame = frames[-1]
    return f" ({os.path.basename(frame.filename)}, line {frame.lineno})"


def _text(value, show=str) -> str:
    """``show(value)`` on one line, or a stand-in if even that raises."""
    try:
        return " ".join(show(value).split())
    except Exception:
        return f"<{type(value).__name__} that cannot be shown>"


def _words(error: BaseException) -> str:
    text = _text(error)
    return f"{type(error).__name__}{': ' + text[:300] if text else ''}"


def resolve_function(spec: str):
    """``"package.module:function"`` → the callable (ValueError, one line, if it is not one).

    Parameters
    ----------
    spec : str
        ``MODULE:FUNCTION``, as ``oracle check`` takes it; ``FUNCTION`` may
        be dotted (``"package.module:Class.method"``). The module must be
        importable (on ``sys.path``).

    Returns
    -------
    callable

    Raises
    ------
    ValueError
        If ``spec`` is not ``MODULE:FUNCTION``, the module does not import
        (is missing, has a syntax error, raises or exits while importing), or
        the name is not a callable of it.

    Examples
    --------
    >>> resolve_function("refsynth.oracle:refsynth_reference").__name__
    'refsynth_reference'
    """
    import importlib

    if not isinstance(spec, str) or spec.count(":") != 1:
        raise ValueError(f"The function must be given as MODULE:FUNCTION, got {spec!r}")
    module, name = spec.split(":")
    if not module or not name:
        raise ValueError(f"The function must be given as MODULE:FUNCTION, got {spec!r}")
    try:
        loaded = importlib.import_module(module)
    except KeyboardInterrupt:
        raise
    except SyntaxError as error:
        raise ValueError(f"Cannot import module {module!r} of {spec!r}: SyntaxError: "
                         f"{error.msg} ({os.path.basename(error.filename or '?')}, line "
                         f"{error.lineno})") from None
    except BaseException as error:   # ImportError, an exception or sys.exit() at import
        raise ValueError(f"Cannot import module {module!r} of {spec!r}: {_words(error)}"
                         f"{_where(error)}") from None
    function = loaded
    for part in name.split("."):
        function = getattr(function, part, None)
    if not callable(function):
        raise ValueError(f"{spec!r}: module {module!r} has no callable {name!r}")
    return function


def _describe(value) -> str:
    if value is None:
        return "None"
    if isinstance(value, (str, bytes)):
        return f"a {type(value).__name__} {_text(value)[:40]!r}"
    if isinstance(value, np.ndarray):
        return f"an array of {value.dtype} (not numbers)"
    return f"a {type(value).__name__}"


def portable_result(got, wanted) -> Outcome:
    """The function's return value checked: None, or the ``wanted`` keys as numeric arrays."""
    if got is None:
        return Outcome("none")
    if not isinstance(got, Mapping):
        return Outcome("result-type", text=f"the function returned {_describe(got)}, not a "
                       "dict of arrays (or None for a kind it does not handle)")
    out = {}
    for key, value in got.items():
        if not isinstance(key, str):
            return Outcome("result-type", text=f"the function returned a dict with the key "
                           f"{key!r}; the keys must be the arrays' names")
        if key not in wanted:
            continue
        try:
            array = np.asarray(value)
        except Exception as error:   # ragged lists, objects numpy refuses
            return Outcome("array", text=f"{key}: expected an array of numbers, got "
                           f"{_describe(value)} ({_words(error)})")
        if array.dtype.kind not in "biuf":
            return Outcome("array", text=f"{key}: expected an array of numbers, got "
                           f"{_describe(value if not isinstance(value, np.ndarray) else array)}")
        out[key] = np.array(array, copy=True)
    return Outcome("result", out)


def call(function, inputs: dict, options: dict, wanted, *, worker: bool = False) -> Outcome:
    """One call: its result, or what it raised or exited with, in words.

    In the worker (``worker=True``, where Ctrl-C is ignored) a KeyboardInterrupt can only
    be the function's own, and is reported as such; in this process it stops the check.
    """
    try:
        got = function(inputs, options)
    except KeyboardInterrupt as error:
        if not worker:
            raise
        return Outcome("raised", text=f"the function raised {_words(error)}{_where(error)}")
    except SystemExit as stop:
        return Outcome("exited", text=f"the function exited (SystemExit: "
                       f"{_text(stop.code, repr)}; a port must return, not call sys.exit)"
                       f"{_where(stop)}")
    except BaseException as error:
        return Outcome("raised", text=f"the function raised {_words(error)}{_where(error)}")
    try:
        return portable_result(got, wanted)
    except Exception as error:   # a Mapping whose items() raises …
        return Outcome("result-type", text=f"the function's result could not be read: "
                       f"{_words(error)}")


def _serve(connection, target) -> None:
    """The worker's loop: import the function, then answer one call per message."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C is the parent's to handle
    try:
        function = resolve_function(target) if isinstance(target, str) else target
    except BaseException as error:
        connection.send(("import", _text(error) or f"Cannot import {target!r}: "
                         f"{type(error).__name__}"))
        return
    connection.send(("ready", ""))
    while True:
        try:
            message = connection.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        inputs, options, wanted = message
        outcome = call(function, inputs, options, wanted, worker=True)
        try:
            connection.send(("outcome", outcome))
        except Exception as error:   # nothing numeric fails to pickle; belt and braces
            connection.send(("outcome", Outcome("result-type", text=f"the result could not "
                                                f"be sent back: {_words(error)}")))


def start_method(target) -> str:
    """How the worker starts: the platform's default for ``"MODULE:FUNCTION"`` (imported
    afresh there); ``fork`` for a callable where there is one (any callable, closures too),
    else the default (which needs a picklable function)."""
    methods = multiprocessing.get_all_start_methods()   # the platform's default first
    if not isinstance(target, str) and "fork" in methods:
        return "fork"
    return methods[0]


class Runner:
    """Calls ``target`` (a callable, or ``"MODULE:FUNCTION"``) case by case, in a worker.

    Use as a context manager; :meth:`call` gives an :class:`Outcome`. The
    worker starts (and imports the function) on entry: a module that cannot
    be imported, or that takes longer than the time limit to import, raises
    ``ValueError`` there, in one line naming the module.
    """

    def __init__(self, target, timeout: float | None):
        self.target, self.timeout = target, timeout
        self.process = self.connection = None
        self.function = None

    def __enter__(self) -> Runner:
        if self.timeout is None:
            self.function = (resolve_function(self.target) if isinstance(self.target, str)
                             else self.target)
        else:
            self._start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop(kill=exc[0] is not None)

    def _start(self) -> None:
        context = multiprocessing.get_context(start_method(self.target))
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, self.target),
                                       name="refsynth-oracle-check")
        with warnings.catch_warnings():   # fork in a process with (BLAS) threads
            warnings.simplefilter("ignore", DeprecationWarning)
            self.process.start()
        child.close()
        what = (f"module {self.target.split(':')[0]!r}" if isinstance(self.target, str)
                else "the function")
        if not self.connection.poll(self.timeout):
            self._stop(kill=True)
            raise ValueError(f"Importing {what} took longer than the time limit of "
                             f"{self.timeout:g} s")
        try:
            kind, text = self.connection.recv()
        except (EOFError, OSError):
            code = self._stop(kill=True)
            raise ValueError(f"The worker process ended while importing {what} "
                             f"({_status(code)})") from None
        if kind == "import":
            self._stop(kill=True)
            raise ValueError(text)

    def _stop(self, kill: bool) -> int | None:
        process, connection = self.process, self.connection
        self.process = self.connection = None
        if process is None:
            return None
        try:
            if not kill:
                connection.send(None)
                process.join(2.0)
        except (OSError, ValueError):
            pass
        if process.is_alive():
            process.kill()
        process.join()
        connection.close()
        return process.exitcode

    def call(self, inputs: dict, options: dict, wanted) -> Outcome:
        """One case: the function's outcome within the time limit."""
        if self.timeout is None:   # copies, as the worker gets: the golden arrays stay put
            inputs = {key: np.array(value, copy=True) for key, value in inputs.items()}
            return call(self.function, inputs, dict(options), wanted)
        if self.process is None:
            self._start()
        try:
            self.connection.send((inputs, options, tuple(wanted)))
        except (OSError, ValueError):
            return Outcome("died", text=f"the worker process ended ({_status(self._stop(True))})")
        if not self.connection.poll(self.timeout):
            self._stop(kill=True)
            return Outcome("timeout", text=f"no result within the time limit of "
                           f"{self.timeout:g} s (the call was stopped; --timeout sets the "
                           "limit)")
        try:
            kind, outcome = self.connection.recv()
        except (EOFError, OSError):
            code = self._stop(kill=True)
            return Outcome("died", text=f"the function ended the worker process "
                           f"({_status(code)})")
        return outcome


def _status(code: int | None) -> str:
    if code is None:
        return "no exit status"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"
