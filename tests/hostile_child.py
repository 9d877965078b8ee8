"""Running ``imucalib`` in a child process under resource limits, for the hostile-input tests.

The child sets RLIMIT_AS (its address space) and RLIMIT_CPU (its processor time) before importing anything,
runs the command, and reports its peak resident memory (``VmHWM`` of its own ``/proc/self/status``): memory
and time bounds are asserted from the process, not from the wall clock.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
#: the address space a command may use on a hostile input [bytes]: the interpreter, numpy and scipy take
#: about 150 MB of it calibrating a real session
ADDRESS_SPACE = 1 << 30
#: processor seconds a command may use on a hostile input
CPU_SECONDS = 60

_LIMITED = """\
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({space}, {space}))
resource.setrlimit(resource.RLIMIT_CPU, ({cpu}, {cpu}))
from imucalib.cli import main
try:
    code = main(sys.argv[1:])
finally:
    peak = next(ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM:'))
    sys.stderr.write(f'\\nPEAK_KB {{peak}}\\n')
sys.exit(code)
"""


def limited(*args, cwd=None, space=ADDRESS_SPACE, cpu=CPU_SECONDS, env=None):
    """``imucalib ARGS`` in a child under RLIMIT_AS ``space`` and RLIMIT_CPU ``cpu``: (exit code, stdout,
    stderr without the peak line, peak resident memory [kB])."""
    env = {**os.environ, "PYTHONPATH": str(SRC), "OPENBLAS_NUM_THREADS": "1", **(env or {})}
    r = subprocess.run([sys.executable, "-c", _LIMITED.format(space=space, cpu=cpu), *map(str, args)],
                       capture_output=True, text=True, cwd=cwd, env=env, timeout=10 * cpu)
    found = re.search(r"\nPEAK_KB (\d+)\n", r.stderr)
    err = r.stderr.replace(found.group(0), "\n") if found else r.stderr
    return r.returncode, r.stdout, err.strip(), int(found.group(1)) if found else 0


def in_process(capsys, *args):
    """``imucalib ARGS`` in this process, for the commands whose input is small and whose point is the exit code
    and the message, not the memory or time a process takes: (exit code, stdout, stripped stderr, ``None``, as no
    peak memory is measured); starting a child costs ~0.4 processor seconds before the command runs."""
    from imucalib.cli import main

    capsys.readouterr()
    try:
        code = main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's refusals: the exit status a child would end with
        assert isinstance(exit_.code, int), exit_.code
        code = exit_.code
    out, err = capsys.readouterr()
    return code, out, err.strip(), None


def one_line(err: str) -> bool:
    """One line of error, no traceback."""
    return "Traceback" not in err and err.count("\n") == 0 and err.startswith("imucalib ")


