"""A live picture of a guided recording in the browser: a local page from the standard library's HTTP server.

:class:`LiveView` follows the events of a :class:`~imucalib.record.Recorder`
and serves, on ``127.0.0.1`` only (nothing leaves the machine, nothing is
fetched from the internet), a page that asks for ``/state.json`` four times
a second and draws the coverage sphere — the up-directions of the rest and
the poses held, the current orientation and the suggested next one, the
upper and the lower half seen from above — with the checklist of what is
still missing and the last messages.
"""

from __future__ import annotations

import http.server
import json
import threading

import numpy as np

from .guidance import up_directions

__all__ = ["LiveView", "PAGE"]


class LiveView:
    """The events of a session, and the recorder's current orientation, served as a page and ``/state.json``.

    Parameters
    ----------
    recorder : Recorder, optional
        Read for the current orientation (the mean of its last tenth of a second).
    port : int
        The local port (0: any free one; :attr:`url` says which).

    Examples
    --------
    The page is served on a free local port until :meth:`close`:

    >>> import json, urllib.request
    >>> from imucalib.record.view import LiveView
    >>> view = LiveView()
    >>> view.url
    'http://127.0.0.1:.../'
    >>> with urllib.request.urlopen(view.url + "state.json") as reply:
    ...     sorted(json.load(reply))[:4]
    ['checklist', 'complete', 'current', 'holding']
    >>> view.close()
    """

    def __init__(self, recorder=None, *, port: int = 0) -> None:
        self.recorder = recorder
        self._lock = threading.Lock()
        self._state = {"status": "waiting for the stream …", "poses": [], "suggestion": None, "holding": None,
                       "checklist": None, "messages": [], "complete": False, "verdict": None, "updates": 0}
        view = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):
                if self.path.split("?")[0] == "/state.json":
                    body, kind = json.dumps(view.state()).encode(), "application/json"
                elif self.path in ("/", "/index.html"):
                    body, kind = PAGE.encode(), "text/html; charset=utf-8"
                else:
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Content-Type", kind)
                self.send_header("Cache-Control", "no-store")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self.server.daemon_threads = True
        self._thread = threading.Thread(target=self.server.serve_forever, daemon=True, name="imucalib-view")
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server.server_port}/"

    def __call__(self, event: dict) -> None:
        kind = event["event"]
        with self._lock:
            s = self._state
            if kind == "pose":
                s["poses"] = [{"up": u, "pose": k} for k, u in enumerate(event.get("directions", []))]
                s["checklist"] = event.get("checklist")
                s["holding"] = None
                s["status"] = f"pose {event['pose']} done: {event['words']}"
            elif kind == "next_pose":
                s["suggestion"] = {"up": event["up"], "words": event["words"]}
            elif kind == "holding":
                s["holding"] = {"up": event["up"], "words": event["words"], "seconds": event["seconds"],
                                "already_held": event.get("already_held")}
                s["status"] = f"holding {event['words']} … {event['seconds']:.1f} s"
            elif kind == "rest":
                s["status"] = event.get("message") or f"initial rest: keep still … {event.get('remaining_s')} s"
            elif kind in ("warning", "silence", "complete"):
                s["messages"] = [*s["messages"], event["message"]][-5:]
                s["complete"] = s["complete"] or kind == "complete"
            elif kind == "end":
                s["verdict"] = event.get("verdict") or "none"
                s["status"] = "the session has ended"

    def state(self) -> dict:
        """What the page draws (a JSON-able dict), the current orientation read from the recorder."""
        with self._lock:
            self._state["updates"] += 1
            out = json.loads(json.dumps(self._state))
        out["current"] = self._current()
        return out

    def _current(self) -> list[float] | None:
        rec = self.recorder
        if rec is None or rec.format is None or rec.n < 2:
            return None
        raw, n = rec._raw, rec.n
        mean = raw[max(n - rec.block, 0):n, 1:4].mean(axis=0)
        means = list(rec._means)
        try:
            dirs, _ = up_directions(np.vstack([*means, mean]), gravity=rec.gravity, trial=rec.trial)
        except (ValueError, FloatingPointError):
            return None
        up = dirs[-1]
        return up.tolist() if np.all(np.isfinite(up)) else None

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>imucalib record</title>
<style>
body { font-family: sans-serif; margin: 1em; background: #fafafa; color: #222; }
#status { font-size: 1.3em; margin: 0.3em 0 0.8em; }
.halves { display: flex; gap: 2em; }
figure { margin: 0; text-align: center; }
ul { list-style: none; padding-left: 0; }
li.ok::before { content: "\\2713  "; color: green; }
li.no::before { content: "\\2717  "; color: #c00; }
#verdict { font-weight: bold; font-size: 1.2em; }
</style></head>
<body>
<h1>imucalib record</h1>
<div id="status">connecting …</div>
<div class="halves">
 <figure><svg id="upper" width="260" height="260" viewBox="-1.1 -1.1 2.2 2.2"></svg>
  <figcaption>z up half (seen from above)</figcaption></figure>
 <figure><svg id="lower" width="260" height="260" viewBox="-1.1 -1.1 2.2 2.2"></svg>
  <figcaption>z down half (seen from below)</figcaption></figure>
 <div><h2>still missing</h2><ul id="missing"></ul><h2>faces</h2><ul id="faces"></ul>
  <p>suggested next: <b id="next">–</b></p><p id="verdict"></p></div>
</div>
<h2>messages</h2><ul id="messages"></ul>
<p><small>updates: <span id="updates">0</span></small></p>
<script>
const NS = "http://www.w3.org/2000/svg";
function dot(svg, u, r, fill, stroke, cls) {
  const c = document.createElementNS(NS, "circle");
  const flip = u[2] < 0 ? -1 : 1;
  c.setAttribute("cx", u[0]); c.setAttribute("cy", -flip * u[1]); c.setAttribute("r", r);
  c.setAttribute("fill", fill); c.setAttribute("stroke", stroke); c.setAttribute("stroke-width", 0.03);
  c.setAttribute("class", cls); svg.appendChild(c);
}
function frame(svg) {
  svg.innerHTML = "";
  const c = document.createElementNS(NS, "circle");
  c.setAttribute("r", 1); c.setAttribute("fill", "white"); c.setAttribute("stroke", "#888");
  c.setAttribute("stroke-width", 0.01); svg.appendChild(c);
}
function list(id, items) {
  const ul = document.getElementById(id); ul.innerHTML = "";
  for (const [text, ok] of items) {
    const li = document.createElement("li"); li.textContent = text;
    if (ok !== null) li.className = ok ? "ok" : "no"; ul.appendChild(li);
  }
}
async function update() {
  try {
    const s = await (await fetch("/state.json", {cache: "no-store"})).json();
    document.getElementById("status").textContent = s.status;
    document.getElementById("updates").textContent = s.updates;
    const up = document.getElementById("upper"), lo = document.getElementById("lower");
    frame(up); frame(lo);
    const half = u => (u[2] >= 0 ? up : lo);
    for (const p of s.poses) dot(half(p.up), p.up, 0.07, p.pose === 0 ? "#999" : "#2a2", "#060", "pose");
    if (s.suggestion) dot(half(s.suggestion.up), s.suggestion.up, 0.1, "none", "#e80", "suggestion");
    if (s.current) dot(half(s.current), s.current, 0.05, "#27f", "#039", "current");
    document.getElementById("next").textContent = s.suggestion ? s.suggestion.words : "–";
    const cl = s.checklist;
    list("missing", cl ? cl.missing.map(m => [m, false]) : []);
    list("faces", cl ? Object.entries(cl.faces) : []);
    list("messages", s.messages.map(m => [m, null]));
    document.getElementById("verdict").textContent = s.verdict ? "verdict: " + s.verdict
      : (s.complete ? "COMPLETE: enough poses for an accepted calibration" : "");
  } catch (e) {
    document.getElementById("status").textContent = "the recorder has stopped";
  }
}
update(); setInterval(update, 250);
</script></body></html>
"""
