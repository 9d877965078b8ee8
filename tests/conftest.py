"""Test-wide settings: property tests are reproducible by default; the suite runs on every core, and one more.

The hypothesis suites draw the same examples on every run (``derandomize``), so a test run on
a clean clone passes or fails the same way each time; ``IMUCALIB_EXPLORE=1`` draws new
examples (and keeps the failing ones in ``.hypothesis/``) to look for new faults.

With pytest-xdist installed (the ``test`` extra) the suite runs in one process per core and one more
(:func:`workers`) unless the command line gives ``-n`` itself (``-n 0``: one process) or names test
files. The recorder's tests wait on the clock (real-time replays, silent peers): a process more than the
cores keeps the cores busy meanwhile, and keeps the suite's share of a machine other work is running on
(2 cores with one CPU-bound process beside the suite: 154 s with 3 processes, 155 s with 4, 191-198 s
with 2; with nothing else running 122 s against 128 s). Each test file runs whole in one process
(``--dist loadfile``), so a file's module-scoped set-up is built once, not once per process (the suite
took 259 CPU-s against 278 CPU-s with ``--dist load``). Each process keeps numpy's BLAS to one thread,
as the fits' matrices are small and processes each starting BLAS threads would only contend.

The studies marked ``slow`` (Monte Carlo studies, long comparisons on real recordings, real-time
replays, processes run against the clock or a limit — silent peers, kills mid-write, memory-limited
children —, clusters of processes, the papers' reproductions, the documentation pages' examples) are left
out by ``python -m pytest -q`` (``addopts`` in ``pyproject.toml``); ``python -m pytest -q -m slow`` runs
them, as ``.ci/run`` does after the rest.
"""

import importlib.util
import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # before numpy is imported, here and in the worker processes

# The suite starts about a hundred Python processes (its workers, the command line's children). Where the
# environment forbids compiled modules (PYTHONDONTWRITEBYTECODE, as in many containers, to keep the source tree
# clean) each of them compiled imucalib and its imports from source again: 0.5 CPU-s an import instead of 0.3,
# about a tenth of the suite's time. The suite's own processes keep their compiled modules in pytest's cache
# folder instead, never beside the sources (PYTHONPYCACHEPREFIX, Python ≥ 3.8); a prefix set already is kept.
if os.environ.get("PYTHONDONTWRITEBYTECODE") and not os.environ.get("PYTHONPYCACHEPREFIX"):
    del os.environ["PYTHONDONTWRITEBYTECODE"]
    os.environ["PYTHONPYCACHEPREFIX"] = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                                     ".pytest_cache", "pycache")

import pytest  # noqa: E402

try:
    from hypothesis import settings
except ImportError:  # the test extra is not installed: the property tests skip themselves
    settings = None

if settings is not None:
    settings.register_profile("reproducible", derandomize=True, deadline=None, database=None)
    settings.register_profile("explore", deadline=None)
    settings.load_profile("explore" if os.environ.get("IMUCALIB_EXPLORE") else "reproducible")


def workers() -> int:
    """The suite's processes: the cores this process may run on, and one more."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return cores + 1


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config):
    """``-n <workers()> --dist loadfile`` for a run of the suite or of a folder of it, when pytest-xdist is
    installed and the command line gives no ``-n`` (or ``-p no:xdist``); a run of named test files stays in one
    process (starting the workers would take longer than the tests)."""
    if importlib.util.find_spec("xdist") is None or not config.pluginmanager.hasplugin("xdist"):
        return
    if os.environ.get("PYTEST_XDIST_WORKER") or config.option.collectonly:
        return
    if any("::" in arg or not os.path.isdir(arg) for arg in config.args):
        return
    if getattr(config.option, "numprocesses", None) is None and getattr(config.option, "dist", "no") == "no":
        config.option.numprocesses = workers()
        config.option.dist = "loadfile"


@pytest.fixture
def spiky_handheld():
    """A factory: hand-held seed 5 with ``n`` gyroscope spikes (+8000 counts), each mid-way through another
    rotation (rotations 3, 7, 11, … between the poses tedaldi2014 finds), on the axes x, y, z in turn;
    returns ``(sim, recording)``."""
    def make(n: int):
        from imucalib.methods import calibrate
        from imucalib.recording import Recording
        from imucalib.scenarios import session

        sim = session("handheld", rng=5)
        rec = sim.recording
        poses = calibrate(rec, method="tedaldi2014", gravity=sim.truth.gravity).fit["intervals"]
        gyro = rec.gyro.copy()
        for k in range(n):
            gyro[(poses[3 + 4 * k][1] + poses[4 + 4 * k][0]) // 2, k % 3] += 8000
        return sim, Recording(rec.t, rec.acc, gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)

    return make
