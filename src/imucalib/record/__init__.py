"""Guided recording: a live stream of samples, kept as it comes, with what to do next.

:func:`record` reads a sensor's text stream (standard input, a serial port,
a TCP socket, phyphox's remote-access interface: :func:`open_source`) and
writes the session to ``OUTPUT.partial`` as it goes (flushed: readable at any
time, and after a killed process), renamed to ``OUTPUT`` on a clean finish
(the end of the stream, a device or peer that goes away, Ctrl-C or SIGTERM).
The session file holds the stream's header and every row that can be
calibrated, unchanged and in order; a line that is not such a row (text, bytes
that are not text, a reading that is not a finite number within any sensor's
range, a stamp that repeats or goes backwards, a line over 64 KiB) is left out
with one note saying which and why (:mod:`.lines`). Meanwhile a
:class:`Recorder` follows the samples with the code the offline calibration
uses (:mod:`.recorder`):

* the table of the stream is found by the CSV reader
  (:func:`imucalib.io.read` on the first lines: header, units, time column);
* the initial rest is counted down, and starts again when the sensor moves
  (:func:`imucalib.segment.find_initial_rest` on the samples so far);
* poses are found by the accelerometer detector of Tedaldi 2014 run as the
  samples arrive (:class:`imucalib.segment.StillDetector`), said while held
  (``holding``: how long, its direction, how far from the suggested one,
  whether it was already held) and once ended (``pose``: its up-direction in
  words — from a sphere fit once there are four poses, from the trial
  calibration once there is one — and the checklist of faces, corners and
  turns still missing, :mod:`.guidance`);
* the next pose to take (:func:`imucalib.plans.next_poses`), warnings when a
  rotation is too fast for the rate (the gyroscope near its range, or more
  than ``max_step_deg`` per sample, which the attitude integration of Zhang
  2021 eq. 23 cannot follow), a pose wobbles
  (:func:`imucalib.segment.gyro_still`), or samples were lost (a gap in the
  stamps); ``complete`` once a calibration of the session so far by the
  chosen method is accepted (:func:`imucalib.methods.calibrate` and its
  verdict) — of exactly the rows the session file holds at that moment;
* at the end, the calibration of the whole session: its verdict and what to
  record again.

:class:`~imucalib.record.view.LiveView` (``imucalib record --view``) draws it
live in the browser, from a local page of the standard library's HTTP server.

Every event is a dict ``{"event": kind, ...}`` with sample indices (0-based,
into the session's data rows) and times [s from its first sample]:
``format``, ``rest`` (countdown, restart, then done), ``holding``, ``pose``,
``next_pose``, ``warning`` (``kind``: ``bad_line``, ``gap``, ``saturation``,
``fast``, ``wobble``), ``complete``, ``silence`` (no data for a while, by the
clock) and ``end``. The samples are analysed in blocks of a tenth of a
second of the stream, so the events are the same however the lines arrive.
"""

from .guidance import Checklist, checklist
from .lines import MAX_LINE, LineFormat, LineSplitter, RowCheck, TooLong
from .recorder import HEAD_LINES, MAX_STEP_DEG, Recorder
from .session import RecordError, RecordResult, SessionWriter, check_session_output, record
from .sources import (
           FdSource,
           PhyphoxStream,
           ReadlineSource,
           SerialSource,
           SocketSource,
           Source,
           SourceGone,
           open_source,
)

__all__ = ["Recorder", "LineFormat", "LineSplitter", "RowCheck", "TooLong", "SessionWriter", "record",
           "open_source", "RecordResult", "RecordError", "MAX_STEP_DEG", "MAX_LINE", "HEAD_LINES",
           "check_session_output", "Source", "SourceGone", "FdSource", "SocketSource", "SerialSource",
           "ReadlineSource", "PhyphoxStream", "Checklist", "checklist"]
