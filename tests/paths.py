"""Paths of the source checkout that the tests read (the library never reads the checkout)."""

from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENARIO = PROJECT_ROOT / "scenarios" / "default.toml"
EXAMPLE_SET = PROJECT_ROOT / "assets" / "measured" / "beef_round_example"
