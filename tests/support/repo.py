"""The repository the tests run in: its root, whatever folder of ``tests/`` a test file sits in."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
