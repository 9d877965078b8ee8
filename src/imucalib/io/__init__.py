"""Reading recordings (CSV, imu_tk text, MATLAB) and writing them as CSV."""

from .readers import READERS, ReaderError, guess_reader, read
from .writers import write_csv

__all__ = ["READERS", "ReaderError", "guess_reader", "read", "write_csv"]
