"""Test-wide settings: property tests are reproducible by default.

The hypothesis suites draw the same examples on every run (``derandomize``), so a test run on
a clean clone passes or fails the same way each time; ``IMUCALIB_EXPLORE=1`` draws new
examples (and keeps the failing ones in ``.hypothesis/``) to look for new faults.
"""

import os

try:
    from hypothesis import settings
except ImportError:  # the test extra is not installed: the property tests skip themselves
    settings = None

if settings is not None:
    settings.register_profile("reproducible", derandomize=True, deadline=None, database=None)
    settings.register_profile("explore", deadline=None)
    settings.load_profile("explore" if os.environ.get("IMUCALIB_EXPLORE") else "reproducible")
