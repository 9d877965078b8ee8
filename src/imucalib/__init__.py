"""imucalib: calibrate the accelerometer and gyroscope of low-cost MEMS IMUs without equipment."""

from .calibration import Calibration
from .models import TriadModel
from .recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording

__all__ = [
    "Calibration",
    "ImucalibWarning",
    "Interval",
    "Recording",
    "STANDARD_GRAVITY",
    "TriadModel",
    "__version__",
]

__version__ = "0.1.0"
