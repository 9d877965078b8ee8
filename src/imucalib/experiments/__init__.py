"""The papers' experiments and studies: simulated sessions run through the methods, against the truth.

One module per paper, named after it, above the methods and the simulators (which import nothing
from here):

* :mod:`.zhang2021` — Zhang 2021, §IV: eqs. (34)–(35) on the test tosses, the Table I session's demo;
* :mod:`.wang2019` — Wang 2019, §5.1: the Monte Carlo of Tables 2–3, the plan's Fisher information;
* :mod:`.qureshi2017` — Qureshi 2017, §IV: the 18-orientation Monte Carlo;
* :mod:`.evaluate` — parameter errors and the Monte Carlo of any scenario and method;
* :mod:`.verdict_thresholds` — the verdict's thresholds against the hand-held scenario's figures
  (``python -m imucalib.experiments.verdict_thresholds``).

Nothing is imported here, so that ``import imucalib.experiments.X`` loads X alone.
"""
