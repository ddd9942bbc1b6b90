"""Masterless unit tests: make the package importable from a plain checkout."""
import sys
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[2] / 'src'
if str(SOURCE) not in sys.path:
    sys.path.insert(0, str(SOURCE))
