"""Where a live stream comes from: standard input, a serial port, a TCP socket, phyphox.

Every source is read by :meth:`Source.read` with a timeout, so that the
thread reading it looks at its stop flag at least every ``timeout`` seconds,
whether data is flowing or not: Ctrl-C ends a silent stream as fast as a busy
one, and nothing is left blocked inside a read when the process exits. A read
returns the bytes that arrived, ``None`` when none did within the timeout,
``b""`` at the end of the stream, and raises :class:`SourceGone` when the
device or peer went away (a normal end of the session, with its reason).
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import socket
import sys
import time
import urllib.request
from collections.abc import Iterator
from urllib.parse import parse_qs, urlsplit

import numpy as np

__all__ = ["Source", "SourceGone", "FdSource", "SocketSource", "SerialSource", "ReadlineSource", "PhyphoxStream",
           "as_source", "open_source", "MAX_JSON_DEPTH", "MAX_JSON_BYTES"]

#: the fastest baud rate accepted (USB serial adapters reach 12 Mbit/s)
MAX_BAUD = 12_000_000

#: the deepest nesting of arrays and objects taken from a phyphox answer (its buffers are 3 deep)
MAX_JSON_DEPTH = 8
#: the largest phyphox answer read [bytes]
MAX_JSON_BYTES = 64 * 1024 * 1024
_CHUNK = 65536


class SourceGone(Exception):
    """The device or peer went away: the stream has ended (the message says how)."""


class Source:
    """A stream of bytes read with a timeout (see the module docstring)."""

    name = "the stream"

    def read(self, timeout: float) -> bytes | None:  # pragma: no cover - the interface
        raise NotImplementedError


class FdSource(Source):
    """A file descriptor (standard input, a pipe, a file) read with ``select`` and ``os.read``."""

    def __init__(self, fd: int, name: str = "standard input") -> None:
        self.fd, self.name = fd, name

    def read(self, timeout: float) -> bytes | None:
        ready, _, _ = select.select([self.fd], [], [], timeout)
        if not ready:
            return None
        try:
            return os.read(self.fd, _CHUNK)
        except OSError as exc:  # a terminal that was closed: EIO
            raise SourceGone(f"{self.name} closed ({exc.strerror})") from None


class SocketSource(Source):
    """A connected socket (TCP)."""

    def __init__(self, sock: socket.socket, name: str) -> None:
        self.sock, self.name = sock, name

    def read(self, timeout: float) -> bytes | None:
        ready, _, _ = select.select([self.sock], [], [], timeout)
        if not ready:
            return None
        try:
            return self.sock.recv(_CHUNK)
        except OSError as exc:
            raise SourceGone(f"{self.name}: the connection was lost ({exc})") from None


class SerialSource(Source):
    """A pyserial port: read with the port's own timeout; a port that fails has gone away (unplugged)."""

    def __init__(self, port, name: str) -> None:
        self.port, self.name = port, name

    def read(self, timeout: float) -> bytes | None:
        import serial  # optional: pip install imucalib[serial]

        try:
            self.port.timeout = timeout
            waiting = self.port.in_waiting
            data = self.port.read(max(1, min(waiting, _CHUNK)))
        except (serial.SerialException, OSError) as exc:
            raise SourceGone(f"{self.name} went away ({exc})") from None
        return data or None  # pyserial: nothing within the timeout is b""


class ReadlineSource(Source):
    """Any object with ``read1`` or ``readline`` (an in-memory stream, an open file): read blocking.

    Meant for streams that never block for long (files, buffers); a pipe or
    a device is better given as its descriptor (:class:`FdSource`).
    """

    def __init__(self, stream, name: str = "the stream") -> None:
        self.stream, self.name = stream, name

    def read(self, timeout: float) -> bytes | None:
        if hasattr(self.stream, "read1"):
            return self.stream.read1(_CHUNK)
        return self.stream.readline(_CHUNK)


def as_source(stream) -> Source:
    """``stream`` as a :class:`Source`: itself, or an object with ``read1``/``readline`` wrapped."""
    if isinstance(stream, Source):
        return stream
    if hasattr(stream, "read1") or hasattr(stream, "readline"):
        return ReadlineSource(stream)
    raise TypeError(f"not a stream: {stream!r}")


@contextlib.contextmanager
def open_source(spec: str, *, stdin=None) -> Iterator[Source]:
    """A :class:`Source` for ``spec``: ``-``, ``serial:PORT?baud=N``, ``tcp://HOST:PORT``, ``phyphox://HOST:PORT``.

    A context manager: the port or connection is closed on leaving it.

    Parameters
    ----------
    spec : str
        ``-`` (standard input), ``serial:PORT?baud=N`` (a serial port; baud 115200 when not given; needs
        the ``serial`` extra), ``tcp://HOST:PORT`` (lines from a TCP server) or ``phyphox://HOST:PORT``
        (phyphox's remote access on a phone).
    stdin : binary stream, optional
        What ``-`` reads instead of the process's standard input.

    Yields
    ------
    Source
        The lines of the device, connection or stream.

    Raises
    ------
    ValueError
        A spec that is none of these, a serial port without pyserial, an unknown setting, a baud rate out of
        range, or a port or host that cannot be opened; the message gives a spec that works.

    Examples
    --------
    >>> import io
    >>> from imucalib.record import open_source
    >>> with open_source("-", stdin=io.BytesIO(b"t,ax,ay,az" + bytes([10]))) as source:
    ...     type(source).__name__
    'ReadlineSource'
    """
    if spec == "-":
        if stdin is not None:
            yield as_source(stdin)
            return
        yield FdSource(sys.stdin.fileno())
        return
    if spec.startswith("serial:"):
        with _serial_source(spec) as source:
            yield source
        return
    url = urlsplit(spec)
    if url.scheme == "tcp":
        with _tcp_source(spec, url) as source:
            yield source
        return
    if url.scheme == "phyphox":
        if not url.hostname:
            raise ValueError(f"{spec}: give the phone's address, e.g. phyphox://192.168.1.20:8080")
        yield PhyphoxStream(url.hostname, url.port or 8080)
        return
    raise ValueError(f"unknown source {spec!r}: use -, serial:/dev/ttyUSB0?baud=115200, tcp://HOST:PORT or "
                     "phyphox://HOST:8080")


@contextlib.contextmanager
def _serial_source(spec: str) -> Iterator[Source]:
    """:func:`open_source` of ``serial:PORT?baud=N``: the port opened, closed on leaving."""
    try:
        import serial  # pyserial
    except ImportError:
        raise ValueError("a serial port needs pyserial: pip install 'imucalib[serial]'") from None
    port, baud = _serial_settings(spec)
    try:
        port_obj = serial.serial_for_url(port, baudrate=baud, timeout=0.1)
    except serial.SerialException as exc:
        raise ValueError(f"{spec}: cannot open the port ({exc})") from None
    try:
        yield SerialSource(port_obj, f"the serial port {port}")
    finally:
        with contextlib.suppress(Exception):  # a port that went away may fail to close
            port_obj.close()


def _serial_settings(spec: str) -> tuple[str, int]:
    """The port and baud rate of ``serial:PORT?baud=N`` (115200 when not given), checked."""
    rest = spec[len("serial:"):]
    port, _, query = rest.partition("?")
    opts = parse_qs(query, keep_blank_values=True)
    unknown = sorted(set(opts) - {"baud"})
    if unknown:
        raise ValueError(f"{spec}: unknown setting {', '.join(unknown)} of a serial port; the one setting is baud, "
                         "e.g. serial:/dev/ttyUSB0?baud=115200")
    try:
        baud = int(opts.get("baud", ["115200"])[-1])
    except ValueError:
        raise ValueError(f"{spec}: baud must be a whole number of bits per second") from None
    if not 50 <= baud <= MAX_BAUD:
        raise ValueError(f"{spec}: a baud rate of {baud} bits per second is not one a serial port runs at "
                         f"(50 to {MAX_BAUD:,}; 115200 is common)")
    if not port:
        raise ValueError(f"{spec}: name the port, e.g. serial:/dev/ttyUSB0?baud=115200")
    return port, baud


@contextlib.contextmanager
def _tcp_source(spec: str, url) -> Iterator[Source]:
    """:func:`open_source` of ``tcp://HOST:PORT`` (``url`` split): the connection made, closed on leaving."""
    try:
        host, port_no = url.hostname, url.port
    except ValueError:
        host, port_no = None, None
    if not host or not port_no:
        raise ValueError(f"{spec}: give the host and port, e.g. tcp://192.168.1.20:5000")
    try:
        sock = socket.create_connection((host, port_no), timeout=10)
    except OSError as exc:
        raise ValueError(f"{spec}: cannot connect ({exc})") from None
    with sock:
        yield SocketSource(sock, spec)


def _json_depth(text: str) -> int:
    """The deepest nesting of ``[`` and ``{`` in a JSON text (brackets inside strings not counted)."""
    depth = deepest = 0
    in_string = escaped = False
    for c in text:
        if in_string:
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest


class PhyphoxStream(Source):
    """phyphox's remote-access interface as a stream of CSV lines ``t,ax,ay,az,gx,gy,gz`` (m/s², rad/s).

    The experiment on the phone must record the accelerometer with gravity
    (buffers ``accX accY accZ acc_time``, as in phyphox's "Acceleration with g")
    and the gyroscope (``gyrX gyrY gyrZ gyr_time``, as in its "Gyroscope"): one
    experiment holding both, with "Allow remote access" on. Over phyphox's
    remote-interface REST API, ``/control?cmd=start`` starts it and
    ``/get?acc_time=T&accX=T|acc_time…`` returns the values recorded after
    ``T`` (``full`` the first time). The gyroscope is interpolated linearly onto
    the accelerometer's stamps, which are written only once the gyroscope has
    caught up with them (accelerometer samples from before the gyroscope's
    first are not written: they have no rate to go with them).

    An answer larger than :data:`MAX_JSON_BYTES`, nested deeper than
    :data:`MAX_JSON_DEPTH` or not in phyphox's buffer format is an error
    (``OSError``) that names what was wrong; a phone that stops answering has
    gone away (:class:`SourceGone`).
    """

    BUFFERS = ("accX", "accY", "accZ", "gyrX", "gyrY", "gyrZ")

    def __init__(self, host: str, port: int, *, poll: float = 0.1, timeout: float = 5.0) -> None:
        self.base = f"http://{host}:{port}"
        self.name = f"phyphox at {self.base}"
        self.poll, self.timeout = poll, timeout
        self._lines: list[bytes] = [b"t,ax [m/s^2],ay [m/s^2],az [m/s^2],gx [rad/s],gy [rad/s],gz [rad/s]\n"]
        self._since = {"acc": None, "gyr": None}
        self._gyro = np.empty((0, 4))
        self._started = False

    def _get(self, path: str):
        with urllib.request.urlopen(self.base + path, timeout=self.timeout) as r:  # noqa: S310 (a local device)
            body = r.read(MAX_JSON_BYTES + 1)
        if len(body) > MAX_JSON_BYTES:
            raise ValueError(f"an answer larger than {MAX_JSON_BYTES // 2**20} MiB")
        text = body.decode("utf-8")
        if _json_depth(text) > MAX_JSON_DEPTH:
            raise ValueError(f"an answer nested deeper than {MAX_JSON_DEPTH} levels")
        return json.loads(text)

    @staticmethod
    def _buffer(data, key: str) -> np.ndarray:
        try:
            values = np.asarray(data[key]["buffer"], dtype=float)
        except (KeyError, TypeError, ValueError, IndexError):
            raise ValueError(f"no numeric buffer {key!r} in its answer (is the experiment recording the "
                             "accelerometer with g and the gyroscope?)") from None
        if values.ndim != 1:
            raise ValueError(f"the buffer {key!r} is not a list of numbers")
        return values

    def _fetch(self) -> None:
        if not self._started:
            self._get("/control?cmd=start")
            self._started = True
        query = []
        for sensor, names in (("acc", self.BUFFERS[:3]), ("gyr", self.BUFFERS[3:])):
            since = self._since[sensor]
            sel = "full" if since is None else f"{since!r}|{sensor}_time"
            query += [f"{sensor}_time={'full' if since is None else repr(since)}"] + [f"{n}={sel}" for n in names]
        answer = self._get("/get?" + "&".join(query))
        data = answer.get("buffer") if isinstance(answer, dict) else None
        if not isinstance(data, dict):
            raise ValueError("its answer has no 'buffer' object")
        acc = [self._buffer(data, k) for k in ("acc_time", *self.BUFFERS[:3])]
        gyr = [self._buffer(data, k) for k in ("gyr_time", *self.BUFFERS[3:])]
        n_a, n_g = min(map(len, acc)), min(map(len, gyr))
        if n_g:
            self._gyro = np.concatenate([self._gyro, np.column_stack([g[:n_g] for g in gyr])])
            self._since["gyr"] = float(self._gyro[-1, 0])
        if n_a and self._gyro.shape[0] >= 2:
            a = np.column_stack([x[:n_a] for x in acc])
            a = a[(a[:, 0] >= self._gyro[0, 0]) & (a[:, 0] <= self._gyro[-1, 0])]  # where there is a gyroscope
            if a.shape[0]:
                g = np.column_stack([np.interp(a[:, 0], self._gyro[:, 0], self._gyro[:, j]) for j in (1, 2, 3)])
                self._lines += [(",".join(f"{v:.9g}" for v in (*row_a, *row_g)) + "\n").encode()
                                for row_a, row_g in zip(a, g, strict=True)]
                self._since["acc"] = float(a[-1, 0])
                self._gyro = self._gyro[self._gyro[:, 0] >= a[-1, 0] - 1.0]

    def read(self, timeout: float) -> bytes | None:
        """The lines the phone has recorded since the last read (None when it has nothing new)."""
        if not self._lines:
            try:
                self._fetch()
            except (TimeoutError, ConnectionError) as exc:
                raise SourceGone(f"{self.name} stopped answering ({exc})") from None
            except OSError as exc:
                reason = getattr(exc, "reason", exc)
                if isinstance(reason, (TimeoutError, ConnectionError, socket.timeout)):
                    raise SourceGone(f"{self.name} stopped answering ({reason})") from None
                raise OSError(f"{self.name}: {exc}") from None
            except (ValueError, KeyError, TypeError, RecursionError) as exc:
                raise OSError(f"{self.name} answered something that is not phyphox's format: {exc}") from None
            if not self._lines:
                time.sleep(min(self.poll, timeout))
                return None
        out, self._lines = b"".join(self._lines), []
        return out

    def readline(self) -> bytes:
        """The next line (blocking while the phone has nothing new)."""
        while True:
            if self._lines:
                return self._lines.pop(0)
            chunk = self.read(self.poll)
            if chunk:
                self._lines = chunk.splitlines(keepends=True)
