"""The recording guide's figures, drawn from the simulator.

Every figure comes from :func:`imucalib.scenarios.session` with a fixed seed,
so the pictures show what the hand-held scenario simulates
(:mod:`imucalib.scenarios.handheld`: tremor, creep, re-grasps, turns about the
vertical, drops, drift) and what the Zhang 2021 scenario's tosses look like.
The raw counts are turned into m/s² and °/s with the session's own truth.

The documentation build runs this module as a Sphinx extension (``figures`` in
``conf.py``): when the build starts it draws the figures into
``docs/_generated`` unless they are there already and newer than this file
and the package's code.
Run it by hand with ``python docs/figures.py [OUTDIR]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUTDIR = HERE / "_generated"

#: file name → drawing function (defined below)
FIGURES: dict = {}

#: seed of the sessions drawn in every figure
SEED = 7
DEG = 180 / np.pi


def _figure(name: str):
    def register(fn):
        FIGURES[name] = fn
        return fn

    return register


def _handheld(**options):
    from imucalib.scenarios import session

    sim = session("handheld", rng=SEED, **options)
    cal = sim.truth.apply(sim.recording)
    return sim, cal


@_figure("pose_sequence.png")
def pose_sequence(plt, cache: dict) -> None:
    """The whole session: the rest, then holds joined by turns; the accelerometer and the gyroscope's speed."""
    sim, cal = cache.setdefault("handheld", _handheld())
    t = cal.t - cal.t[0]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 4.8), sharex=True, constrained_layout=True)
    for ax in (ax1, ax2):
        for k, seg in enumerate(s for s in sim.segments if s.kind == "static"):
            ax.axvspan(t[seg.start], t[seg.stop - 1], color="#d9ead3" if k else "#c9daf8", lw=0)
    for i, (axis, colour) in enumerate(zip("xyz", ("C0", "C1", "C2"), strict=True)):
        ax1.plot(t, cal.acc[:, i], colour, lw=0.7, label=f"{axis}")
    ax1.set_ylabel("accelerometer [m/s²]")
    ax1.legend(loc="upper right", ncol=3, fontsize=8)
    ax2.plot(t, np.linalg.norm(cal.gyro, axis=1) * DEG, "k", lw=0.6)
    ax2.set_ylabel("turn rate [°/s]")
    ax2.set_xlabel("time [s]")
    rest = sim.segments[0]
    ax1.annotate("initial rest on the table", xy=(t[rest.stop - 1] / 2, 10.5), ha="center", fontsize=8)
    n = sum(s.kind == "static" for s in sim.segments) - 1
    ax1.set_title(f"A hand-held session: a {t[rest.stop - 1]:.0f} s rest, then {n} holds (green) joined by turns",
                  fontsize=10)


@_figure("static_intervals.png")
def static_intervals(plt, cache: dict) -> None:
    """The same hold with a steady hand and with a shaking one: turn rate and the accelerometer's wander."""
    good_sim, good = cache.setdefault("handheld", _handheld())
    bad_sim, bad = cache.setdefault("shaky", _handheld(tremor=2.0))
    k = 5  # the fifth hold after the rest
    fig, axes = plt.subplots(2, 2, figsize=(9, 4.6), sharex="col", sharey="row", constrained_layout=True)
    for col, (sim, cal, title) in enumerate(((good_sim, good, "good: steady hand, 0.15 °/s tremor"),
                                             (bad_sim, bad, "bad: shaking hand, 2 °/s tremor"))):
        seg = [s for s in sim.segments if s.kind == "static"][k]
        sl = slice(seg.start, seg.stop)
        t = cal.t[sl] - cal.t[seg.start]
        rate = np.linalg.norm(cal.gyro[sl], axis=1) * DEG
        acc = cal.acc[sl] - cal.acc[sl].mean(axis=0)
        axes[0, col].plot(t, rate, "k", lw=0.7)
        axes[0, col].set_title(title, fontsize=10)
        for i, axis in enumerate("xyz"):
            axes[1, col].plot(t, acc[:, i], lw=0.7, label=axis)
        sd = float(np.sqrt(np.mean(np.var(cal.acc[sl], axis=0))))
        axes[1, col].text(0.02, 0.9, f"σ = {sd * 1000:.0f} mm/s² per axis", transform=axes[1, col].transAxes,
                          fontsize=8)
        axes[0, col].text(0.02, 0.88, f"RMS {np.sqrt(np.mean(rate**2)):.2f} °/s", transform=axes[0, col].transAxes,
                          fontsize=8)
        axes[1, col].set_xlabel("time in the hold [s]")
    axes[0, 0].set_ylabel("turn rate [°/s]")
    axes[1, 0].set_ylabel("accelerometer − mean [m/s²]")
    axes[1, 1].legend(loc="lower right", ncol=3, fontsize=8)


@_figure("coverage_sphere.png")
def coverage_sphere(plt, cache: dict) -> None:
    """Gravity directions of the holds on the unit sphere: all around, and only the upper half."""
    from imucalib.metrics import interval_means, pose_coverage

    sim, cal = cache.setdefault("handheld", _handheld())
    holds = [s for s in sim.segments if s.kind == "static"]
    up = interval_means(cal.acc, holds)
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    half = up[up[:, 2] > -0.2]  # the poses of someone who never turns the sensor face down
    fig = plt.figure(figsize=(9, 4.4), constrained_layout=True)
    u, v = np.mgrid[0:2 * np.pi:25j, 0:np.pi:13j]
    for col, (dirs, title) in enumerate(((up, "good: every axis up and down"),
                                         (half, "bad: z never points down"))):
        ax = fig.add_subplot(1, 2, col + 1, projection="3d")
        ax.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", lw=0.4)
        ax.scatter(dirs[:, 0], dirs[:, 1], dirs[:, 2], c=np.where(dirs[:, 2] >= 0, "C0", "C3"), s=18, depthshade=False)
        flags = pose_coverage(dirs)[1]
        ax.set_title(f"{title}\n{len(dirs)} poses, {len(flags)} coverage flag{'s' * (len(flags) != 1)}",
                     fontsize=10)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # three ticks a unit apart: the labels cannot overlap
            axis.set_ticks([-1, 0, 1])
        ax.tick_params(labelsize=8, pad=0)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=18, azim=-60)


@_figure("record_view.png")
def record_view(plt, cache: dict) -> None:
    """What ``imucalib record --view`` draws, six poses into a session: the halves of the sphere, the checklist."""
    import tempfile

    from imucalib.io import write_csv
    from imucalib.record import Recorder

    sim, _ = cache.setdefault("handheld", _handheld())
    with tempfile.TemporaryDirectory() as tmp:
        write_csv(Path(tmp) / "s.csv", sim.recording)
        lines = (Path(tmp) / "s.csv").read_bytes().splitlines(keepends=True)
    events: list[dict] = []
    recorder = Recorder(events.append)
    for k in range(0, len(lines), 10):
        recorder.feed(lines[k:k + 10])
        if sum(e["event"] == "pose" for e in events) >= 6:
            break
    pose = [e for e in events if e["event"] == "pose"][-1]
    nxt = [e for e in events if e["event"] == "next_pose"][-1]
    dirs = np.asarray(pose["directions"])
    fig, axes = plt.subplots(1, 3, figsize=(10, 3.6), constrained_layout=True,
                             gridspec_kw={"width_ratios": [1, 1, 1.2]})
    t = np.linspace(0, 2 * np.pi, 200)
    for ax, sign, title in ((axes[0], 1, "z up half (from above)"), (axes[1], -1, "z down half (from below)")):
        ax.plot(np.cos(t), np.sin(t), color="0.6", lw=0.8)
        mine = dirs[np.sign(dirs[:, 2] + 1e-12) == sign]
        ax.scatter(mine[:, 0], sign * mine[:, 1], s=60, c="C2", edgecolors="k", zorder=3, label="held")
        for u, style in ((np.asarray(nxt["up"]), dict(s=180, facecolors="none", edgecolors="C1", linewidths=2,
                                                              label="suggested next")),):
            if np.sign(u[2] + 1e-12) == sign:
                ax.scatter([u[0]], [sign * u[1]], zorder=4, **style)
        ax.set_aspect("equal")
        ax.set_xlim(-1.15, 1.15)
        ax.set_ylim(-1.15, 1.15)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title, fontsize=9)
    axes[0].legend(loc="lower left", fontsize=7, frameon=False)
    cl = pose["checklist"]
    text = [f"pose {pose['pose']} done: {pose['words']}", f"now turn to {nxt['words']}", "", "faces:"]
    text += [f"  {'[x]' if ok else '[ ]'} {name}" for name, ok in cl["faces"].items()]
    text += [f"corners {cl['corners']}/8, turned about "
             + " ".join(a for a, ok in cl["turned"].items() if ok), "still missing:"]
    text += [f"  {m}" for m in cl["missing"][:6]]
    axes[2].axis("off")
    axes[2].text(0, 1, "\n".join(text), va="top", family="monospace", fontsize=7.5, transform=axes[2].transAxes)


@_figure("tremor_creep.png")
def tremor_creep(plt, cache: dict) -> None:
    """A hold that begins with creep, and the spectrum of hand tremor (sway 0.5–2 Hz, tremor 8–12 Hz)."""
    from scipy.signal import welch

    sim, cal = cache.setdefault("handheld", _handheld())
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6), constrained_layout=True)
    creep = sim.options["creep_sections"][0]["range"]
    hold = next(s for s in sim.segments if s.kind == "static" and s.start <= creep[0] < s.stop)
    sl = slice(hold.start, hold.stop)
    t = cal.t[sl] - cal.t[hold.start]
    ax1.plot(t, np.linalg.norm(cal.gyro[sl], axis=1) * DEG, "k", lw=0.7)
    ax1.axvspan(cal.t[creep[0]] - cal.t[hold.start], cal.t[min(creep[1], hold.stop) - 1] - cal.t[hold.start],
                color="#f4cccc", lw=0)
    ax1.set_xlabel("time in the hold [s]")
    ax1.set_ylabel("turn rate [°/s]")
    ax1.set_title(f"creep: the hand settles {sim.options['creep_sections'][0]['angle_deg']:.1f}° (red), then holds",
                  fontsize=10)
    rate = cal.rate
    for tremor, colour in ((0.15, "C0"), (2.0, "C3")):
        s, c = cache.setdefault("shaky", _handheld(tremor=2.0)) if tremor == 2.0 else (sim, cal)
        longest = max((x for x in s.segments[1:] if x.kind == "static"), key=len)
        w = c.gyro[longest.slice] * DEG
        f, p = welch(w - w.mean(axis=0), fs=rate, nperseg=min(256, len(w)), axis=0)
        ax2.semilogy(f, p.sum(axis=1), colour, lw=1, label=f"{tremor:g} °/s RMS tremor")
    ax2.axvspan(0.5, 2, color="0.9", lw=0)
    ax2.axvspan(8, 12, color="0.9", lw=0)
    ax2.set_xlabel("frequency [Hz]")
    ax2.set_ylabel("turn-rate PSD [(°/s)²/Hz]")
    ax2.set_title("tremor: sway (0.5–2 Hz) and tremor (8–12 Hz)", fontsize=10)
    ax2.legend(fontsize=8)


@_figure("toss.png")
def toss(plt, cache: dict) -> None:
    """One spinning toss of the Zhang 2021 scenario: in the air the accelerometer feels no gravity, only the spin."""
    from imucalib.scenarios import session

    sim = session("zhang2021", rng=SEED, n1=4, n2=1, n3=1)
    seq = sim.tests[0]
    cal = sim.truth.apply(seq.recording)
    t = cal.t - cal.t[0]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 4), sharex=True, constrained_layout=True)
    for seg in seq.segments:
        if seg.kind == "weightless":
            for ax in (ax1, ax2):
                ax.axvspan(t[seg.start], t[seg.stop - 1], color="#fce5cd", lw=0)
    ax1.plot(t, np.linalg.norm(cal.acc, axis=1), "k", lw=0.8)
    ax1.axhline(sim.truth.gravity, color="0.6", lw=0.6, ls="--")
    ax1.set_ylabel("|a| [m/s²]")
    ax1.set_title("A toss: held, thrown spinning (orange: in the air, no gravity felt, only the spin's "
                  "centripetal acceleration), caught, held", fontsize=9)
    ax2.plot(t, np.linalg.norm(cal.gyro, axis=1) * DEG, "k", lw=0.8)
    ax2.set_ylabel("turn rate [°/s]")
    ax2.set_xlabel("time [s]")


def draw(outdir: Path = OUTDIR, *, names=None) -> list[Path]:
    """Draw the figures (all, or ``names``) into ``outdir``; the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir.mkdir(parents=True, exist_ok=True)
    cache: dict = {}
    written = []
    for name, fn in FIGURES.items():
        if names is not None and name not in names:
            continue
        with plt.rc_context({"font.size": 9, "savefig.dpi": 110}):
            fn(plt, cache)
            path = outdir / name
            plt.savefig(path)
            plt.close("all")
        written.append(path)
    return written


def stale(outdir: Path = OUTDIR) -> list[str]:
    """Names of the figures missing from ``outdir`` or older than this file or the package's code."""
    sources = [Path(__file__), *(HERE.parent / "src" / "imucalib").rglob("*.py")]
    newest = max(p.stat().st_mtime for p in sources if p.is_file())
    return [n for n in FIGURES if not (outdir / n).is_file() or (outdir / n).stat().st_mtime < newest]


def _on_builder_inited(app) -> None:
    missing = stale()
    if missing:
        draw(names=missing)


def setup(app) -> dict:
    """Sphinx extension: draw the figures when the build starts."""
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}


if __name__ == "__main__":
    for p in draw(Path(sys.argv[1]) if len(sys.argv) > 1 else OUTDIR):
        print(p)
